#pragma once
// Adaptive quadtree image grids (Bimber et al. sections 5-7): a (2^m + 1) x (2^m + 1) vertex
// matrix refined recursively (Algorithm 1, RecursiveGridRefinement) with GeneratePatch (the
// convex container test of 7.1), TransformPatchVertices (the display optics, once per vertex
// and frame) and RefineFurther (the image space error of 7.2-7.4); T-vertex counters give the
// crack-free triangulation of LOD transitions. Also the uniform grid baseline.
//
// Matrix indices: vertex (x, y) has texture coordinates (x, y) / 2^m, x right, y down. A patch at
// LOD n is the square of side h = 2^(m-n) with top-left L-vertex (px h, py h); its X-vertex is
// the centre, its T-vertices the side midpoints. Patches exist for LOD 0 .. m-1 (an X-vertex
// needs h >= 2).

#include <cstdint>
#include <memory>
#include <vector>

#include <plx/core/status.h>
#include <plx/display/container.h>
#include <plx/display/optics.h>

namespace plx::display {

// A warp mesh: the image grid after TransformPatchVertices, ready for the second pass.
struct WarpMesh {
    int gridLevel = 0;               // m: the vertex matrix is (2^m + 1)^2
    std::vector<uint32_t> gridIds;   // per vertex: matrix index y * (2^m + 1) + x
    std::vector<DVec2> uvs;          // per vertex: texture coordinates in the pass-1 image
    std::vector<DVec2> displayPos;   // per vertex: 2D display coordinates
    std::vector<uint32_t> indices;   // three per triangle, into the per-vertex arrays
    size_t triangleCount() const { return indices.size() / 3; }
    size_t vertexCount() const { return uvs.size(); }
};

struct WarpStats {
    uint64_t vertexTransformations = 0;  // TransformPatchVertices calls that did work
    uint64_t patches = 0;                // patches generated (the set P)
    uint64_t leafPatches = 0;            // patches rendered
    uint64_t culledPatches = 0;          // GeneratePatch said no (container or optics)
    uint64_t balanceRefinements = 0;     // refinements forced by the LOD difference rule
    uint64_t containerRayTests = 0;      // Moller-Trumbore ray-triangle tests
    uint64_t errorSamples = 0;           // image space error evaluations
    int deepestLevel = 0;
    SolverStats solver;
};

struct QuadtreeConfig {
    int gridLevel = 9;              // m, in [2, 11]
    double thresholdMm = 1.0;       // the image space error threshold (delta_is bar)
    // Lambda of section 7.4: patches at LOD >= Lambda evaluate only the edge in the direction of
    // their parent's largest error. The paper uses 3; a value > gridLevel disables the heuristic.
    int errorDirectionLevel = 3;
    // Lowest LOD a patch may stop at (the root patch alone cannot see the curvature between its
    // four corners).
    int minLevel = 1;
    // Fraction kappa of the threshold: a patch at LOD >= Lambda whose one inherited side has an
    // error in (kappa * threshold, threshold] samples its other three sides as well before it
    // stops (1: the paper's heuristic unguarded). 0.75 keeps the dense-validated bound on every
    // shipped display over random viewpoints (0.9 does not on the dome at 0.1 mm).
    double errorDirectionRecheck = 0.75;
};

// Generates adaptive warp meshes frame after frame, keeping its vertex matrix between frames so
// that a frame allocates nothing once warm.
class QuadtreeWarper {
public:
    // Checks the configuration (gridLevel in [2, 11], threshold finite and > 0).
    static Result<std::unique_ptr<QuadtreeWarper>> create(const QuadtreeConfig& config);
    ~QuadtreeWarper();

    const QuadtreeConfig& config() const;
    // Precondition (checked, abort): finite and > 0, as create requires.
    void setThresholdMm(double thresholdMm);

    // Runs RecursiveGridRefinement for the viewer's image plane, balances the LODs and
    // triangulates the leaves. container may be null or empty (no spatial limit).
    void generate(const Display& display, const ImagePlane& plane, const Container* container,
                  WarpMesh* mesh, WarpStats* stats);

private:
    struct Impl;
    explicit QuadtreeWarper(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// The uniform baseline: (2^level + 1)^2 vertices, every one transformed, two triangles per cell
// (the grids of the paper's Fig. 2). Cells with a vertex the optics cannot map are left out.
// Precondition (checked, abort): level in [0, 12].
void generateUniform(const Display& display, const ImagePlane& plane, int level, WarpMesh* mesh,
                     WarpStats* stats);

// Result of checking a mesh's triangles for cracks.
struct CrackReport {
    size_t edges = 0;
    size_t boundaryEdges = 0;      // used by one triangle
    size_t overusedEdges = 0;      // used by more than two triangles
    size_t tJunctions = 0;         // a mesh vertex strictly inside a triangle edge
    size_t imageBorderViolations = 0;  // boundary edges off the image border (full grids only)
};

// Checks that every edge is shared by at most two triangles and that no vertex lies inside an
// edge (T-junction); counts boundary edges away from the image border.
CrackReport checkCracks(const WarpMesh& mesh);

}  // namespace plx::display
