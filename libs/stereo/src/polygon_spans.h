#pragma once
// A cheap pre-test of the hole fill (fill.h): may a convex polygon's projection cover a sample
// of given pixel spans? Asked before setting up a triangle for span scan conversion.

#include <span>

#include <plx/core/core.h>
#include <plx/raster/span_fill.h>

namespace plx::stereo {

// Whether the projection of a convex polygon (its corners in order) may cover the sample of a
// pixel in `spans` (row order). False only when every span on the polygon's rows has both end
// samples outside one edge by more than a rounding margin; corners nearer than the near plane,
// or a polygon of no area, answer true.
bool polygonMayCoverSpans(const Camera& camera, std::span<const Vec3> corners,
                          std::span<const raster::PixelSpan> spans);

}  // namespace plx::stereo
