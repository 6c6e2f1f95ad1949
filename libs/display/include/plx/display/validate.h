#pragma once
// Validation of warp meshes: the image space error measured densely over every triangle, the
// check that the threshold of RefineFurther actually holds between the sample points.

#include <plx/display/quadtree.h>

namespace plx {
class ThreadPool;
}

namespace plx::display {

struct ErrorMeasurement {
    double maxErrorMm = 0.0;
    double meanErrorMm = 0.0;
    uint64_t samples = 0;
    uint64_t unmapped = 0;  // samples the optics could not map back (counted, not in the max)
};

// Samples every triangle on the barycentric lattice with `divisions` steps per edge (vertices
// excluded: they are exact by construction), maps each displayed point back through the optics
// and measures its error against the texture coordinates it carries (section 7.2).
// Preconditions: divisions >= 2; mesh produced for this display and image plane. pool may be
// null (single thread).
ErrorMeasurement measureMeshError(const Display& display, const ImagePlane& plane,
                                  const WarpMesh& mesh, int divisions, ThreadPool* pool);

}  // namespace plx::display
