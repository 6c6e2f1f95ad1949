// Span-restricted scan conversion (span_fill.h) over the reference renderer's setup and rows.

#include <plx/raster/span_fill.h>

#include <algorithm>

#include "pipeline.h"

namespace plx::raster {
namespace {

// The snapped triangle's edges with the top-left bias of the coverage test, for asking of a span
// whether it may hold a covered sample: a span whose two end samples lie outside the same edge
// has every sample between them outside it too, the edge function being linear along the row.
// The test rejects only spans without a covered sample, so the rasterizer would write nothing in
// a span it rejects; it passes a few more (a span with its ends outside two different edges).
class SpanEdges {
public:
    SpanEdges(const detail::RasterVertex vin[3], const detail::TriangleBox& box) : mBox(box) {
        detail::orientPositive(vin, box.area2, mV);
        for (int i = 0; i < 3; ++i) {
            const int j = (i + 1) % 3;
            mBias[i] = detail::topLeftBias(mV[j]->x - mV[i]->x, mV[j]->y - mV[i]->y);
        }
    }

    bool mayCover(const PixelSpan& s) const {
        const int x0 = std::max(s.x0, mBox.minX), x1 = std::min(s.x1, mBox.maxX);
        if (x0 > x1) return false;
        constexpr int64_t kScale = detail::kSubPixelScale;
        const int64_t py = int64_t(s.y) * kScale + kScale / 2;
        const int64_t px0 = int64_t(x0) * kScale + kScale / 2;
        const int64_t px1 = int64_t(x1) * kScale + kScale / 2;
        for (int i = 0; i < 3; ++i) {
            const int j = (i + 1) % 3;
            const detail::RasterVertex &a = *mV[i], &b = *mV[j];
            if (detail::edgeAt(a.x, a.y, b.x, b.y, px0, py) + mBias[i] < 0 &&
                detail::edgeAt(a.x, a.y, b.x, b.y, px1, py) + mBias[i] < 0)
                return false;
        }
        return true;
    }

private:
    const detail::TriangleBox& mBox;
    const detail::RasterVertex* mV[3];
    int64_t mBias[3];
};

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
        // Decided before the setup, which a large triangle passing beside a few hole pixels
        // would otherwise pay for nothing; and per span after it: three in four spans of a
        // triangle's rows in the reproject fill hold none of its samples (office:280).
        const SpanEdges edges(tris[i], box);
        first = std::find_if(first, last, [&](const PixelSpan& s) { return edges.mayCover(s); });
        if (first == last) continue;
        detail::TriangleSetup t;
        detail::setTriangleIdentity(scene, mesh, local, &t);
        detail::isa_scalar::setupTriangleInBox(scene, mesh, local, tris[i], box, ctx, &t);
        for (auto s = first; s != last; ++s)
            if (s == first || edges.mayCover(*s))
                written += detail::rasterizeReferenceRow(t, ctx, targets, s->y, s->x0, s->x1);
    }
    return written;
}

}  // namespace plx::raster
