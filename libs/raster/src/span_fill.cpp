// Span-restricted scan conversion (span_fill.h) over the reference renderer's setup and rows.

#include <plx/raster/span_fill.h>

#include <algorithm>

#include "pipeline.h"

namespace plx::raster {
namespace {

// Whether the snapped triangle may cover a sample of one of the spans [first, last): a span
// whose two end samples lie outside the same edge (with the top-left bias of the coverage
// test) has every sample between them outside it too, the edge function being linear along
// the row. Decides before the setup, which a large triangle passing beside a few hole pixels
// would otherwise pay for nothing.
template <class It>
bool mayCoverSpans(const detail::RasterVertex vin[3], const detail::TriangleBox& box, It first,
                   It last) {
    const detail::RasterVertex* v[3];
    detail::orientPositive(vin, box.area2, v);
    int64_t bias[3];
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        bias[i] = detail::topLeftBias(v[j]->x - v[i]->x, v[j]->y - v[i]->y);
    }
    constexpr int64_t kScale = detail::kSubPixelScale;
    for (It s = first; s != last; ++s) {
        const int x0 = std::max(s->x0, box.minX), x1 = std::min(s->x1, box.maxX);
        if (x0 > x1) continue;
        const int64_t py = int64_t(s->y) * kScale + kScale / 2;
        const int64_t px0 = int64_t(x0) * kScale + kScale / 2;
        const int64_t px1 = int64_t(x1) * kScale + kScale / 2;
        bool outside = false;
        for (int i = 0; i < 3 && !outside; ++i) {
            int j = (i + 1) % 3;
            int64_t e0 = detail::edgeAt(v[i]->x, v[i]->y, v[j]->x, v[j]->y, px0, py) + bias[i];
            int64_t e1 = detail::edgeAt(v[i]->x, v[i]->y, v[j]->x, v[j]->y, px1, py) + bias[i];
            outside = e0 < 0 && e1 < 0;
        }
        if (!outside) return true;
    }
    return false;
}

}  // namespace

int64_t drawTriangleInSpans(const scene::Scene& scene, uint32_t globalTriangle,
                            const Camera& camera, const RenderOptions& options,
                            const RenderTargets& targets, std::span<const PixelSpan> spans) {
    PLX_CHECK(globalTriangle < scene.triangleCount());
    PLX_CHECK(!options.colorOnly && targets.depth.data && targets.id.data);
    PLX_CHECK(targets.depth.width == camera.width() && targets.depth.height == camera.height());
    PLX_CHECK(targets.id.width == camera.width() && targets.id.height == camera.height());
    PLX_DCHECK(std::is_sorted(spans.begin(), spans.end(),
                              [](const PixelSpan& a, const PixelSpan& b) { return a.y < b.y; }));
    detail::Viewport vp(camera);
    detail::ShadeContext ctx(options, targets);
    detail::RasterVertex tris[detail::kMaxClippedTriangles][3];
    size_t mesh;
    uint32_t local;
    int count = detail::clipReferenceTriangle(scene, globalTriangle, camera, vp, tris, &mesh, &local);
    int64_t written = 0;
    for (int i = 0; i < count; ++i) {
        // isa_scalar::setupTriangle in its steps, the setup only for a triangle that may cover
        // a sample of the spans.
        detail::TriangleBox box;
        if (!detail::triangleBox(tris[i][0], tris[i][1], tris[i][2], vp, ctx.cullBackFaces, &box))
            continue;
        auto first = std::lower_bound(spans.begin(), spans.end(), box.minY,
                                      [](const PixelSpan& p, int y) { return p.y < y; });
        auto last = first;
        while (last != spans.end() && last->y <= box.maxY) ++last;
        if (!mayCoverSpans(tris[i], box, first, last)) continue;
        detail::TriangleSetup t;
        detail::setTriangleIdentity(scene, mesh, local, &t);
        detail::isa_scalar::setupTriangleInBox(scene, mesh, local, tris[i], box, ctx, &t);
        for (auto s = first; s != last; ++s)
            written += detail::rasterizeReferenceRow(t, ctx, targets, s->y, s->x0, s->x1);
    }
    return written;
}

}  // namespace plx::raster
