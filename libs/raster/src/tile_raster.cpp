// The fast pixel loop: scanline spans from exact integer edge functions.
//
// For each row, each edge's half-plane E(x) >= -bias is solved for x with one integer division,
// so the inner loop visits only covered samples and needs no inside test. Barycentric weights
// come from the same exact int64 edge values as in the reference (converted to float once per
// sample), so depth, IDs and colours are bit-identical to reference.cpp.

#include <algorithm>

#include "pipeline.h"

namespace plx::raster::detail {
namespace {

inline int64_t floorDiv(int64_t a, int64_t b) {  // b > 0
    int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

// Narrows [lo, hi] (pixel offsets from the row start) to where e + a * k + bias >= 0.
inline void narrowSpan(int64_t e, int64_t a, int64_t bias, int64_t* lo, int64_t* hi) {
    int64_t c = e + bias;
    if (a == 0) {
        if (c < 0) *hi = -1, *lo = 0;  // empty
    } else if (a > 0) {
        // c + a k >= 0  <=>  k >= ceil(-c / a)
        *lo = std::max(*lo, -floorDiv(c, a));
    } else {
        // c + a k >= 0  <=>  k <= floor(c / -a)
        *hi = std::min(*hi, floorDiv(c, -a));
    }
}

// Writes one covered sample (depth test, ID, colour). e1, e2: unbiased edge values of edges 2 and
// 0, proportional to the barycentric weights b1 and b2.
template <Shading kShading, bool kColor, bool kLayer2>
inline void writeSample(const TriangleSetup& t, const ShadeContext& ctx, int64_t e1, int64_t e2,
                        float invArea, float* depth, uint32_t* id, Rgba8* color, float* depth2,
                        uint32_t* id2) {
    float b1 = float(e1) * invArea, b2 = float(e2) * invArea;
    float invW = t.invW[0] + b1 * (t.invW[1] - t.invW[0]) + b2 * (t.invW[2] - t.invW[0]);
    if (!(invW > *depth)) {
        if constexpr (kLayer2) {
            if (invW > *depth2) {
                *depth2 = invW;
                *id2 = t.id;
            }
        }
        return;
    }
    if constexpr (kLayer2) {
        *depth2 = *depth;
        *id2 = *id;
    }
    *depth = invW;
    *id = t.id;
    if constexpr (kColor) {
        if constexpr (kShading == Shading::kFlat)
            *color = flatColorFor(t, ctx);
        else
            *color = shadeSample(t, ctx, b1, b2, invW);
    }
}

// Small triangles: walk the bounding box testing the signs of the three incrementally stepped
// edge values. Cheaper than solving spans when rows are only a few pixels long.
template <Shading kShading, bool kColor, bool kLayer2>
void rasterizeBox(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                  int x0, int y0, int x1, int y1) {
    int64_t ax[3], by[3], rowE[3];
    const int64_t sx = int64_t(x0) * kSubPixelScale + kSubPixelScale / 2;
    const int64_t sy = int64_t(y0) * kSubPixelScale + kSubPixelScale / 2;
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        ax[i] = -int64_t(t.y[j] - t.y[i]) * kSubPixelScale;
        by[i] = int64_t(t.x[j] - t.x[i]) * kSubPixelScale;
        // Biased so that "covered" is simply e >= 0 for all three edges.
        rowE[i] = int64_t(t.x[j] - t.x[i]) * (sy - t.y[i]) -
                  int64_t(t.y[j] - t.y[i]) * (sx - t.x[i]) + t.edgeBias[i];
    }
    const float invArea = 1.0f / float(t.area2);
    for (int y = y0; y <= y1; ++y, rowE[0] += by[0], rowE[1] += by[1], rowE[2] += by[2]) {
        int64_t e0 = rowE[0], e1 = rowE[1], e2 = rowE[2];
        float* depthRow = rt.depth.row(y);
        uint32_t* idRow = rt.id.row(y);
        Rgba8* colorRow = kColor ? rt.color.row(y) : nullptr;
        float* depth2Row = kLayer2 ? rt.depth2.row(y) : nullptr;
        uint32_t* id2Row = kLayer2 ? rt.id2.row(y) : nullptr;
        for (int x = x0; x <= x1; ++x, e0 += ax[0], e1 += ax[1], e2 += ax[2]) {
            if ((e0 | e1 | e2) < 0) continue;
            writeSample<kShading, kColor, kLayer2>(
                t, ctx, e2 - t.edgeBias[2], e0 - t.edgeBias[0], invArea, depthRow + x, idRow + x,
                kColor ? colorRow + x : nullptr, kLayer2 ? depth2Row + x : nullptr,
                kLayer2 ? id2Row + x : nullptr);
        }
    }
}

template <Shading kShading, bool kColor, bool kLayer2>
void rasterizeSpans(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                    int x0, int y0, int x1, int y1) {
    // Edge i runs from vertex i to vertex j = i+1; stepping one pixel in x adds ax[i], in y by[i].
    int64_t ax[3], by[3], rowE[3];
    const int64_t sx = int64_t(x0) * kSubPixelScale + kSubPixelScale / 2;
    const int64_t sy = int64_t(y0) * kSubPixelScale + kSubPixelScale / 2;
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        ax[i] = -int64_t(t.y[j] - t.y[i]) * kSubPixelScale;
        by[i] = int64_t(t.x[j] - t.x[i]) * kSubPixelScale;
        rowE[i] = int64_t(t.x[j] - t.x[i]) * (sy - t.y[i]) - int64_t(t.y[j] - t.y[i]) * (sx - t.x[i]);
    }
    const float invArea = 1.0f / float(t.area2);
    const int64_t width = x1 - x0;
    for (int y = y0; y <= y1; ++y, rowE[0] += by[0], rowE[1] += by[1], rowE[2] += by[2]) {
        int64_t lo = 0, hi = width;
        for (int i = 0; i < 3; ++i) narrowSpan(rowE[i], ax[i], t.edgeBias[i], &lo, &hi);
        if (lo > hi) continue;
        // Edge 2 (2->0) is proportional to b1, edge 0 (0->1) to b2.
        int64_t e1 = rowE[2] + ax[2] * lo, e2 = rowE[0] + ax[0] * lo;
        float* depthRow = rt.depth.row(y);
        uint32_t* idRow = rt.id.row(y);
        Rgba8* colorRow = kColor ? rt.color.row(y) : nullptr;
        float* depth2Row = kLayer2 ? rt.depth2.row(y) : nullptr;
        uint32_t* id2Row = kLayer2 ? rt.id2.row(y) : nullptr;
        for (int64_t k = lo; k <= hi; ++k, e1 += ax[2], e2 += ax[0]) {
            int x = x0 + int(k);
            writeSample<kShading, kColor, kLayer2>(
                t, ctx, e1, e2, invArea, depthRow + x, idRow + x, kColor ? colorRow + x : nullptr,
                kLayer2 ? depth2Row + x : nullptr, kLayer2 ? id2Row + x : nullptr);
        }
    }
}

}  // namespace

void rasterizeTriangle(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                       int x0, int y0, int x1, int y1) {
    x0 = std::max(x0, t.minX);
    y0 = std::max(y0, t.minY);
    x1 = std::min(x1, t.maxX);
    y1 = std::min(y1, t.maxY);
    if (x0 > x1 || y0 > y1) return;
    // Rows of up to kBoxWidth pixels are tested pixel by pixel; longer rows solve their span
    // (three integer divisions a row) so large triangles touch only covered samples.
    constexpr int kBoxWidth = 24;
    bool box = x1 - x0 < kBoxWidth;
    bool color = rt.color.data != nullptr;
    bool flat = ctx.shading == Shading::kFlat;
    auto run = [&]<Shading kS, bool kC, bool kL2>() {
        if (box)
            rasterizeBox<kS, kC, kL2>(t, ctx, rt, x0, y0, x1, y1);
        else
            rasterizeSpans<kS, kC, kL2>(t, ctx, rt, x0, y0, x1, y1);
    };
    if (rt.id2.data) {
        if (!color) run.template operator()<Shading::kFlat, false, true>();
        else if (flat) run.template operator()<Shading::kFlat, true, true>();
        else run.template operator()<Shading::kGouraud, true, true>();
        return;
    }
    if (flat && color) run.template operator()<Shading::kFlat, true, false>();
    else if (flat) run.template operator()<Shading::kFlat, false, false>();
    else if (color) run.template operator()<Shading::kGouraud, true, false>();
    else run.template operator()<Shading::kGouraud, false, false>();
}

}  // namespace plx::raster::detail
