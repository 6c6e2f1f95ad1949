// The mesh reconstruction (splat.h; beyond the paper): each 2x2 quad of source pixels is two
// triangles rasterised in the destination, torn at depth discontinuities. Scalar: the quads
// share their vertices' warps, computed once per row pair with warpPixel.

#include <algorithm>
#include <bit>
#include <cmath>

#include <plx/warp/splat.h>

#include "warp_internal.h"

namespace plx::warp::detail {

namespace {

struct Vertex {
    WarpedPoint p;
    float sourceDelta;
    uint32_t color;
};

// Whether a triangle is drawn: in front of the destination, no depth discontinuity, no
// background/foreground mix, and no larger than a splat (splat.h).
bool keepTriangle(const Vertex& a, const Vertex& b, const Vertex& c) {
    if (!(a.p.denominator > 0.0f && b.p.denominator > 0.0f && c.p.denominator > 0.0f))
        return false;
    const float lo = std::min({a.sourceDelta, b.sourceDelta, c.sourceDelta});
    const float hi = std::max({a.sourceDelta, b.sourceDelta, c.sourceDelta});
    if (hi > 0.0f && (lo <= 0.0f || hi - lo > kMeshTearRatio * hi)) return false;
    const float w = std::max({a.p.x, b.p.x, c.p.x}) - std::min({a.p.x, b.p.x, c.p.x});
    const float h = std::max({a.p.y, b.p.y, c.p.y}) - std::min({a.p.y, b.p.y, c.p.y});
    return w <= kMaxSplatSize && h <= kMaxSplatSize;
}

// Rasterises one triangle: pixel centres inside or on its edges, 1/w interpolated (affine in
// the destination image for a plane), the colour of the vertex with the largest weight.
template <WriteMode kMode>
void drawTriangle(const Writer& writer, const Vertex& a, const Vertex& b, const Vertex& c) {
    if (!keepTriangle(a, b, c)) return;
    const float area = (b.p.x - a.p.x) * (c.p.y - a.p.y) - (b.p.y - a.p.y) * (c.p.x - a.p.x);
    if (!(std::fabs(area) > 1e-12f)) return;
    const float inv = 1.0f / area;
    const int x0 = std::max(0, int(std::ceil(std::min({a.p.x, b.p.x, c.p.x}) - 0.5f)));
    const int x1 = std::min(writer.dest.width - 1, int(std::floor(std::max({a.p.x, b.p.x, c.p.x}) - 0.5f)));
    const int y0 =
        std::max(writer.bandY0, int(std::ceil(std::min({a.p.y, b.p.y, c.p.y}) - 0.5f)));
    const int y1 =
        std::min(writer.bandY1 - 1, int(std::floor(std::max({a.p.y, b.p.y, c.p.y}) - 0.5f)));
    for (int y = y0; y <= y1; ++y) {
        const float py = float(y) + 0.5f;
        for (int x = x0; x <= x1; ++x) {
            const float px = float(x) + 0.5f;
            const float wa = ((b.p.x - px) * (c.p.y - py) - (b.p.y - py) * (c.p.x - px)) * inv;
            const float wb = ((c.p.x - px) * (a.p.y - py) - (c.p.y - py) * (a.p.x - px)) * inv;
            const float wc = 1.0f - wa - wb;
            if (wa < 0.0f || wb < 0.0f || wc < 0.0f) continue;
            const float delta = wa * a.p.delta + wb * b.p.delta + wc * c.p.delta;
            const uint32_t color = wa >= wb ? (wa >= wc ? a.color : c.color)
                                            : (wb >= wc ? b.color : c.color);
            const uint64_t key = uint64_t(std::bit_cast<uint32_t>(std::max(delta, 0.0f)) + 1u);
            writeWord<kMode>(writer, size_t(y) * writer.dest.stride + size_t(x), key << 32 | color);
        }
    }
}

template <WriteMode kMode>
void meshRowT(const ViewJob& view, const RowJob& row, const Writer& writer,
              std::vector<Vertex>* rows, std::span<const int32_t> order) {
    const ReferenceView& v = *view.view;
    const int width = v.disparity.width();
    const int xEnd = std::min(row.x1 + 1, width);
    const int n = xEnd - row.x0;
    rows[0].resize(size_t(std::max(n, 0)));
    rows[1].resize(size_t(std::max(n, 0)));
    for (int r = 0; r < 2; ++r) {
        const int y = row.y + r;
        const float* disparity = v.disparity.row(y);
        const Rgba8* color = v.color.row(y);
        for (int x = row.x0; x < xEnd; ++x) {
            Vertex& vx = rows[r][size_t(x - row.x0)];
            warpPixel(view.w, x, y, disparity[x], &vx.p);
            vx.sourceDelta = disparity[x];
            vx.color = disparity[x] > 0.0f ? rgbaBits(color[x]) : writer.dest.clearBits;
        }
    }
    auto quad = [&](int x) {
        if (x + 1 >= xEnd) return;
        const size_t i = size_t(x - row.x0);
        const Vertex &p00 = rows[0][i], &p10 = rows[0][i + 1], &p01 = rows[1][i],
                     &p11 = rows[1][i + 1];
        drawTriangle<kMode>(writer, p00, p10, p01);
        drawTriangle<kMode>(writer, p10, p11, p01);
    };
    if (order.empty()) {
        for (int x = row.x0; x < row.x1; ++x) quad(x);
    } else {
        for (int32_t x : order) quad(x);
    }
}

}  // namespace

void meshRow(const ViewJob& view, const RowJob& row, const Writer& writer,
             std::span<const int32_t> order) {
    thread_local std::vector<Vertex> rows[2];
    switch (writer.mode) {
        case WriteMode::kMax: return meshRowT<WriteMode::kMax>(view, row, writer, rows, order);
        case WriteMode::kAtomicMax:
            return meshRowT<WriteMode::kAtomicMax>(view, row, writer, rows, order);
        case WriteMode::kPainter:
            return meshRowT<WriteMode::kPainter>(view, row, writer, rows, order);
    }
}

}  // namespace plx::warp::detail
