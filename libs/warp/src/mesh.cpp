// The mesh reconstruction (splat.h; beyond the paper): each 2x2 quad of source pixels is two
// triangles rasterised in the destination, torn at depth discontinuities. Scalar: the vertices
// are warped once per frame with warpPixel (transformMeshRow), then the bands draw the quads.

#include <algorithm>
#include <bit>
#include <cmath>

#include <plx/warp/splat.h>

#include "warp_internal.h"

namespace plx::warp::detail {

namespace {

using Vertex = MeshVertex;

// Whether a triangle is drawn: in front of the destination, no depth discontinuity, no
// background/foreground mix, and no larger than a splat (splat.h).
bool keepTriangle(const Vertex& a, const Vertex& b, const Vertex& c) {
    if (!(a.p.denominator > 0.0f && b.p.denominator > 0.0f && c.p.denominator > 0.0f)) return false;
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
    const int x1 =
        std::min(writer.dest.width - 1, int(std::floor(std::max({a.p.x, b.p.x, c.p.x}) - 0.5f)));
    const int y0 = std::max(writer.bandY0, int(std::ceil(std::min({a.p.y, b.p.y, c.p.y}) - 0.5f)));
    const int y1 =
        std::min(writer.bandY1 - 1, int(std::floor(std::max({a.p.y, b.p.y, c.p.y}) - 0.5f)));
    // Barycentric weights of b and c, affine in the pixel position, taken relative to vertex a
    // (small numbers, so no cancellation) and advanced by constants along each row.
    const float bx = b.p.x - a.p.x, by = b.p.y - a.p.y, cx = c.p.x - a.p.x, cy = c.p.y - a.p.y;
    const float stepB = cy * inv, stepC = -by * inv;
    const float dB = b.p.delta - a.p.delta, dC = c.p.delta - a.p.delta;
    for (int y = y0; y <= y1; ++y) {
        const float py = float(y) + 0.5f - a.p.y;
        const float px = float(x0) + 0.5f - a.p.x;
        float wb = (px * cy - py * cx) * inv;
        float wc = (bx * py - by * px) * inv;
        uint64_t* row = writer.dest.words + size_t(y) * writer.dest.stride;
        for (int x = x0; x <= x1; ++x, wb += stepB, wc += stepC) {
            const float wa = 1.0f - wb - wc;
            const bool inside = wa >= 0.0f && wb >= 0.0f && wc >= 0.0f;
            if (kMode == WriteMode::kPainter && !inside) continue;
            const float delta = a.p.delta + wb * dB + wc * dC;
            const uint32_t color =
                wa >= wb ? (wa >= wc ? a.color : c.color) : (wb >= wc ? b.color : c.color);
            const uint64_t key = uint64_t(std::bit_cast<uint32_t>(std::max(delta, 0.0f)) + 1u);
            // Outside: word 0, which a max leaves unchanged; no branch on the edge tests, whose
            // outcome is a coin toss over a triangle's bounding box.
            const uint64_t word = inside ? key << 32 | color : 0;
            writeWord<kMode>(writer, size_t(row - writer.dest.words) + size_t(x), word);
        }
    }
}

template <WriteMode kMode>
void meshRowT(const ViewJob& view, const RowJob& row, const Writer& writer, const Transformed& t,
              std::span<const int32_t> order) {
    const int width = view.view->disparity.width();
    const int xEnd = std::min(row.x1 + 1, width);
    const size_t n = size_t(row.x1 - row.x0 + 1);
    const Vertex* top = t.vertices.data() + row.offset;
    const Vertex* bottom = top + n;
    auto quad = [&](int x) {
        if (x + 1 >= xEnd) return;
        const size_t i = size_t(x - row.x0);
        drawTriangle<kMode>(writer, top[i], top[i + 1], bottom[i]);
        drawTriangle<kMode>(writer, top[i + 1], bottom[i + 1], bottom[i]);
    };
    if (order.empty()) {
        for (int x = row.x0; x < row.x1; ++x) quad(x);
    } else {
        for (int32_t x : order) quad(x);
    }
}

}  // namespace

std::pair<int32_t, int32_t> transformMeshRow(const ViewJob& view, const RowJob& row,
                                             const DestBuffer& dest, Transformed* out) {
    const ReferenceView& v = *view.view;
    const int xEnd = std::min(row.x1 + 1, v.disparity.width());
    const size_t n = size_t(row.x1 - row.x0 + 1);
    float lo = float(dest.height), hi = 0.0f;
    for (int r = 0; r < 2; ++r) {
        const int y = row.y + r;
        const float* disparity = v.disparity.row(y);
        const Rgba8* color = v.color.row(y);
        Vertex* vertices = out->vertices.data() + row.offset + size_t(r) * n;
        for (int x = row.x0; x < xEnd; ++x) {
            Vertex& vx = vertices[x - row.x0];
            if (warpPixel(view.w, x, y, disparity[x], &vx.p)) {
                vx.p.delta *= view.depthScale;  // the set's compositing handicap (holes.h)
                lo = std::min(lo, vx.p.y);
                hi = std::max(hi, vx.p.y);
            }
            vx.sourceDelta = disparity[x];
            vx.color = disparity[x] > 0.0f ? rgbaBits(color[x]) : dest.clearBits;
        }
    }
    // A drawn triangle's pixel centres lie between its vertices' y (drawTriangle).
    if (!(lo <= hi)) return {0, 0};
    const int32_t y0 = int32_t(std::max(0.0f, std::floor(lo)));
    const int32_t y1 = int32_t(std::min(float(dest.height), std::ceil(hi) + 1.0f));
    return {y0, y1};
}

void meshRow(const ViewJob& view, const RowJob& row, const Writer& writer, const Transformed& t,
             std::span<const int32_t> order) {
    switch (writer.mode) {
        case WriteMode::kMax:
            return meshRowT<WriteMode::kMax>(view, row, writer, t, order);
        case WriteMode::kAtomicMax:
            return meshRowT<WriteMode::kAtomicMax>(view, row, writer, t, order);
        case WriteMode::kPainter:
            return meshRowT<WriteMode::kPainter>(view, row, writer, t, order);
    }
}

}  // namespace plx::warp::detail
