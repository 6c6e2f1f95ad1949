#pragma once
// Reconstruction kernels (Mark, Bishop, McMillan, "Image Reconstruction Kernel"). Each warped
// source pixel is written as an axis-aligned rectangle of destination pixels centred on its
// warped position (x', y'): the pixels whose centres lie in [x' - sx/2, x' + sx/2) x
// [y' - sy/2, y' + sy/2).
//
//   point       sx = sy = 1: the one pixel the position falls in.
//   fixed 2x2   sx = sy = 2.
//   derivative  the paper's sx = |dx'/dx| + |dx'/dy|, sy = |dy'/dx| + |dy'/dy| with
//               dx'/dx = (ddelta/dx (c - i x') + a - g x') / D and likewise (derivativeSplatSize),
//               clamped to [1, kMaxSplatSize]. The disparity derivatives are differences with the
//               neighbouring pixels, the smaller in magnitude of the forward and backward one, so
//               a pixel on a silhouette takes the slope of its own surface, not the depth jump.
//   mesh        (beyond the paper) each 2x2 quad of source pixels is two triangles, rasterised
//               with the destination's 1/w interpolated (exact for planes) and the colour of the
//               nearest vertex; a triangle tears (is not drawn) where its disparities differ by
//               more than kMeshTearRatio of the largest, where one vertex is background
//               (delta = 0) and another not, where it is behind the destination, or where its
//               destination bounding box is wider or taller than kMaxSplatSize pixels.
//
// The default is the derivative splat: it leaves the fewest holes and the best PSNR of the
// four on the measured poses (docs/warp-results.md).

#include <plx/warp/equation.h>

namespace plx::warp {

// The largest splat side in destination pixels. The default display loop (512-pixel faces to a
// 720-pixel-high 60-degree view) magnifies about 2.4x; 6 leaves room for approaching a surface
// to within about half the reference distance, and bounds the row clip's margin.
constexpr float kMaxSplatSize = 6.0f;
// Mesh tear threshold: neighbouring disparities whose difference exceeds this fraction of the
// larger are taken as a depth discontinuity (10%: a 512-pixel cube face's floor keeps its
// triangles to about 5 degrees above the horizon; steeper jumps are silhouettes).
constexpr float kMeshTearRatio = 0.1f;

// The disparity derivative along a row or column from the pixel's neighbours (either may be
// missing at the image border): the smaller in magnitude of the two one-sided differences.
inline float neighbourDerivative(float before, float here, float after) {
    const float back = here - before;
    const float fwd = after - here;
    return (fwd < 0 ? -fwd : fwd) < (back < 0 ? -back : back) ? fwd : back;
}

// The derivative splat size (sx, sy) of a source pixel that warped to (x', y') with denominator
// D, given its disparity derivatives; unclamped (the paper's expression).
struct SplatSize {
    float sx, sy;
};
inline SplatSize derivativeSplatSize(const WarpCoefficients& w, float xp, float yp, float denom,
                                     float ddx, float ddy) {
    const float r = 1.0f / denom;
    const float cx = w.c - w.i * xp;
    const float cy = w.f - w.i * yp;
    const float dxdx = (ddx * cx + (w.a - w.g * xp)) * r;
    const float dxdy = (ddy * cx + (w.b - w.h * xp)) * r;
    const float dydx = (ddx * cy + (w.d - w.g * yp)) * r;
    const float dydy = (ddy * cy + (w.e - w.h * yp)) * r;
    auto absf = [](float v) { return v < 0 ? -v : v; };
    return {absf(dxdx) + absf(dxdy), absf(dydx) + absf(dydy)};
}

}  // namespace plx::warp
