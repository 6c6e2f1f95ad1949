// Per-row clipping of the disparity parallelogram (clip.h; Mark, Bishop, McMillan, "Speedup
// techniques"): Sutherland-Hodgman in the (x, delta) plane, in double.

#include <algorithm>
#include <array>
#include <cmath>

#include <plx/warp/clip.h>

namespace plx::warp {

namespace {

struct P2 {
    double x, delta;
};

// Keeps the part of the convex polygon `in` where the affine function
// s(x, delta) = sx x + sd delta + s0 is >= 0.
int clipHalfPlane(const P2* in, int n, double sx, double sd, double s0, P2* out) {
    int m = 0;
    for (int j = 0; j < n; ++j) {
        const P2& p = in[j];
        const P2& q = in[(j + 1) % n];
        const double sp = sx * p.x + sd * p.delta + s0;
        const double sq = sx * q.x + sd * q.delta + s0;
        if (sp >= 0) out[m++] = p;
        if ((sp >= 0) != (sq >= 0)) {
            const double t = sp / (sp - sq);
            out[m++] = {p.x + t * (q.x - p.x), p.delta + t * (q.delta - p.delta)};
        }
    }
    return m;
}

}  // namespace

RowSpan clipRow(const WarpCoefficients& w, int y, int width, float deltaMin, float deltaMax,
                int destWidth, int destHeight, float marginPx) {
    // Homogeneous destination position of (x, delta) on this row: N = T + A x + B delta.
    const double fy = y;
    const double tx = double(w.b) * fy + w.k, ty = double(w.e) * fy + w.l,
                 td = double(w.h) * fy + w.m;
    const double mg = marginPx;
    const double right = double(destWidth) + mg, bottom = double(destHeight) + mg;
    // Half-planes: D >= 0, x' >= -margin, x' <= W + margin, y' likewise (times D > 0).
    const std::array<std::array<double, 3>, 5> planes = {{
        {w.g, w.i, td},
        {w.a + mg * w.g, w.c + mg * w.i, tx + mg * td},
        {right * w.g - w.a, right * w.i - w.c, right * td - tx},
        {w.d + mg * w.g, w.f + mg * w.i, ty + mg * td},
        {bottom * w.g - w.d, bottom * w.i - w.f, bottom * td - ty},
    }};
    // At most 4 + 5 vertices after five clips.
    P2 bufA[16], bufB[16];
    const double x1 = width - 1;
    bufA[0] = {0, deltaMin};
    bufA[1] = {x1, deltaMin};
    bufA[2] = {x1, deltaMax};
    bufA[3] = {0, deltaMax};
    int n = 4;
    P2* in = bufA;
    P2* out = bufB;
    for (const auto& pl : planes) {
        n = clipHalfPlane(in, n, pl[0], pl[1], pl[2], out);
        std::swap(in, out);
        if (n == 0) return {};
    }
    double lo = in[0].x, hi = in[0].x;
    double ylo = bottom, yhi = -mg;
    for (int j = 0; j < n; ++j) {
        lo = std::min(lo, in[j].x);
        hi = std::max(hi, in[j].x);
        const double d = td + w.g * in[j].x + w.i * in[j].delta;
        if (d > 0) {
            const double yp = (ty + w.d * in[j].x + w.f * in[j].delta) / d;
            ylo = std::min(ylo, yp);
            yhi = std::max(yhi, yp);
        } else {
            // A vertex on D = 0: the polygon reaches the horizon; any row may be hit.
            ylo = -mg;
            yhi = bottom;
        }
    }
    // One pixel of slack each side covers the float kernel's rounding against this double clip.
    RowSpan span;
    span.x0 = std::max(0, int(std::floor(lo)) - 1);
    span.x1 = std::min(width, int(std::ceil(hi)) + 2);
    if (span.x0 >= span.x1) return {};
    // The splat margin is already in the clip planes; one more row for rounding.
    span.y0 = std::max(0, int(std::floor(ylo - mg)) - 1);
    span.y1 = std::min(destHeight, int(std::ceil(yhi + mg)) + 2);
    if (span.y0 >= span.y1) return {};
    return span;
}

}  // namespace plx::warp
