#pragma once
// A cheap pre-test of the hole fill (fill.h): may a convex polygon's projection cover a sample
// of given pixel spans? Asked before setting up a triangle for span scan conversion.

#include <span>

#include <plx/core/core.h>
#include <plx/raster/span_fill.h>
#include <plx/scene/box_hierarchy.h>

namespace plx::stereo {

// Whether the projection of a convex polygon (its corners in order) may cover the sample of a
// pixel in `spans` (row order), all inside `box` (pixels x0 <= x < x1, y0 <= y < y1). False only
// when the samples of the box, or else of every span on the polygon's rows, lie outside one edge
// by more than a rounding margin; corners nearer than the near plane, or a polygon of no area,
// answer true.
bool polygonMayCoverSpans(const Camera& camera, std::span<const Vec3> corners,
                          std::span<const raster::PixelSpan> spans, const scene::PixelRect& box);

}  // namespace plx::stereo
