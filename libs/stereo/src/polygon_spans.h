#pragma once
// A cheap pre-test of the hole fill (fill.h): may a convex polygon's projection cover a sample
// of given pixel spans? Asked before setting up a triangle for span scan conversion.

#include <span>

#include <plx/core/core.h>
#include <plx/raster/span_fill.h>
#include <plx/scene/box_hierarchy.h>
#include <plx/stereo/fill.h>

namespace plx::stereo {

// Whether the projection of a convex polygon (its corners in order) may cover the sample of a
// pixel in `spans` (row order), all inside `box` (pixels x0 <= x < x1, y0 <= y < y1). False only
// when the samples of the box, or else of every span on the polygon's rows, lie outside one edge
// by more than a rounding margin; corners nearer than the near plane, or a polygon of no area,
// answer true.
bool polygonMayCoverSpans(const Camera& camera, std::span<const Vec3> corners,
                          std::span<const raster::PixelSpan> spans, const scene::PixelRect& box);

// The box part of polygonMayCoverSpans for four entries of a box hierarchy's leaves at once.
struct FourTriangles {
    // Bit per triangle: the samples of the box lie outside one of its edges. Never set for a
    // triangle with a corner nearer than the near plane, or with no area.
    uint32_t missBox = 0;
};

// The projections and box test of polygonMayCoverSpans for the four triangles of `corners` from
// `entry` on, with the same margins. Vector operations where the build has them; a triangle it
// rejects, polygonMayCoverSpans rejects too, up to the float rounding its margin covers.
FourTriangles projectFourTriangles(const Camera& camera, const LeafCorners& corners, size_t entry,
                                   const scene::PixelRect& box);

}  // namespace plx::stereo
