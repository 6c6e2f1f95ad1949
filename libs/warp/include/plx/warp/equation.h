#pragma once
// McMillan's perturbed-projective warp (Mark, Bishop, McMillan, "Speedup techniques"):
//
//   x' = (a x + b y + c delta + k) / (g x + h y + i delta + m)
//   y' = (d x + e y + f delta + l) / (g x + h y + i delta + m)
//
// Derivation. A camera's P (a 3x3 matrix, rayFromPixel) maps the pixel position (u, v, 1) to the
// world-space ray whose component along the camera's forward axis is 1, so a point at view depth
// w seen at (u, v) is X = C + w P (u, v, 1). With delta = 1/w (the depth target), the source
// pixel x1 = (u1, v1, 1) sees X = C1 + P1 x1 / delta. In the destination, X = C2 + w2 P2 x2 with
// x2 = (u2, v2, 1), hence
//
//   w2 x2 = P2^-1 (C1 - C2) + P2^-1 P1 x1 / delta;  multiplied by delta:
//   delta w2 x2 = P2^-1 P1 x1 + delta P2^-1 (C1 - C2).
//
// The right side is linear in (u1, v1, 1, delta): the columns of M = P2^-1 P1 give (a d g),
// (b e h), (k l m) and the vector t = P2^-1 (C1 - C2) gives (c f i). The third row is the
// denominator D = delta w2, so the destination's own disparity is delta2 = 1/w2 = delta / D (the
// z-buffer's one extra multiply the paper mentions), and D > 0 is "in front of the destination".
// Source pixel indices (x, y) sit at u1 = x + 0.5, v1 = y + 0.5; WarpCoefficients fold that
// half-pixel into k, l and m, so they take integer indices and give continuous destination
// positions (x', y') whose pixel is (floor x', floor y').
//
// Rows are evaluated incrementally (rowTerms): for a fixed y the three numerators are constants
// plus a x (advancing by a per pixel) plus the delta term.

#include <plx/core/camera.h>

namespace plx::warp {

// The twelve constants of one (source, destination) pair, for source pixel indices.
struct WarpCoefficients {
    float a = 1, b = 0, c = 0, k = 0;  // x' numerator: a x + b y + c delta + k
    float d = 0, e = 1, f = 0, l = 0;  // y' numerator
    float g = 0, h = 0, i = 0, m = 1;  // denominator D = delta * w2
};

// P of the comment above: world-space ray (forward component 1) of pixel position (u, v, 1),
// u, v continuous (pixel (x, y)'s centre is (x + 0.5, y + 0.5)). Principal shift included.
glm::dmat3 rayFromPixel(const Camera& camera);

// The warp from `source` to `destination` (computed in double, rounded once to float).
WarpCoefficients warpCoefficients(const Camera& source, const Camera& destination);

// The terms of row y that do not depend on x or delta: b y + k, e y + l, h y + m.
struct RowTerms {
    float nx, ny, nd;
};
inline RowTerms rowTerms(const WarpCoefficients& w, int y) {
    const float fy = float(y);
    return {w.b * fy + w.k, w.e * fy + w.l, w.h * fy + w.m};
}

// The warp of one source pixel (reference arithmetic, the same operations as the row kernel):
// destination position and disparity; false when the point is not in front of the destination.
struct WarpedPoint {
    float x, y, delta, denominator;
};
inline bool warpPixel(const WarpCoefficients& w, int x, int y, float delta, WarpedPoint* out) {
    const RowTerms t = rowTerms(w, y);
    const float fx = float(x);
    const float nx = (t.nx + w.a * fx) + w.c * delta;
    const float ny = (t.ny + w.d * fx) + w.f * delta;
    const float nd = (t.nd + w.g * fx) + w.i * delta;
    const float r = 1.0f / nd;
    *out = {nx * r, ny * r, delta * r, nd};
    return nd > 0.0f;
}

// The epipole in the source image: where the destination's eye appears, homogeneous in
// continuous source pixel positions, P1^-1 (C2 - C1). z > 0: the destination eye is in front of
// the source camera (McMillan's positive epipole); z < 0: behind it; z = 0: at infinity.
glm::dvec3 sourceEpipole(const Camera& source, const Camera& destination);

}  // namespace plx::warp
