#pragma once
// Per-row clipping (Mark, Bishop, McMillan, "Speedup techniques"). For a fixed source row the
// warp's homogeneous destination position (Nx, Ny, D) is affine in (x, delta), so the row's
// pixels, with delta between the row's min and max disparity, lie in the image of the
// parallelogram [x0, x1] x [deltaMin, deltaMax]. The destination frustum (widened by the
// largest splat) and D >= 0 are half-planes in the same (x, delta) plane, so the parallelogram
// is clipped there as an ordinary convex polygon; the x extent of what remains is the row's
// potentially visible span. Conservative: no pixel outside the span can reach the destination.

#include <plx/warp/equation.h>

namespace plx::warp {

// A source row's potentially visible pixels [x0, x1) (empty when x0 >= x1), and the destination
// rows [y0, y1) that their splats can reach (the clipped polygon's extent; a projective map
// with D > 0 keeps the polygon convex, so its vertices bound it).
struct RowSpan {
    int x0 = 0;
    int x1 = 0;
    int y0 = 0;
    int y1 = 0;
};

// The visible span of source row y (pixels 0..width-1, disparities in [deltaMin, deltaMax]) for a
// destination of destWidth x destHeight pixels, where a splat reaches at most `marginPx` pixels
// from its warped position. Preconditions: 0 <= deltaMin <= deltaMax, width >= 1.
RowSpan clipRow(const WarpCoefficients& w, int y, int width, float deltaMin, float deltaMax,
                int destWidth, int destHeight, float marginPx);

}  // namespace plx::warp
