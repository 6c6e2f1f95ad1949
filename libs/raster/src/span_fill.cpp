// Span-restricted scan conversion (span_fill.h) over the reference renderer's setup and rows.

#include <plx/raster/span_fill.h>

#include <algorithm>

#include "pipeline.h"

namespace plx::raster {
namespace {

// The snapped triangle's three edge functions over the spans, evaluated exactly in integers as
// the reference's row does (edge i from vertex i to i + 1, in setupTriangleInBox's orientation),
// but from values taken once per triangle: each function at the sample of (minX, minY) and its
// steps by a column and by a row. A span's values then cost a multiply-add per edge, where the
// reference's row evaluates each edge and the barycentrics' two from the vertices.
//
// A span whose two end samples lie outside the same edge has every sample between them outside
// it too (the edge function is linear along the row), so the rasterizer would write nothing
// there: such spans are skipped. The test passes a few spans without a covered sample (ends
// outside two different edges); the pixel loop writes nothing in them.
class SpanRows {
public:
    // The values of one span clipped to the box.
    struct Row {
        int x0 = 0, x1 = -1;
        int64_t eAtX0[3];   // biased, at the sample of (x0, y)
        int64_t atMinX[3];  // unbiased, at the sample of (minX, y)
    };

    SpanRows(const detail::RasterVertex vin[3], const detail::TriangleBox& box) : mBox(box) {
        const detail::RasterVertex* v[3];
        detail::orientPositive(vin, box.area2, v);
        constexpr int64_t kScale = detail::kSubPixelScale;
        const int64_t px = int64_t(box.minX) * kScale + kScale / 2;
        const int64_t py = int64_t(box.minY) * kScale + kScale / 2;
        for (int i = 0; i < 3; ++i) {
            const detail::RasterVertex &a = *v[i], &b = *v[(i + 1) % 3];
            mAtCorner[i] = detail::edgeAt(a.x, a.y, b.x, b.y, px, py);
            mBias[i] = detail::topLeftBias(b.x - a.x, b.y - a.y);
            mStepX[i] = -int64_t(b.y - a.y) * kScale;
            mStepY[i] = int64_t(b.x - a.x) * kScale;
        }
    }

    // False when the span, clipped to the box, is empty or lies outside one edge; else its values.
    bool mayCover(const PixelSpan& s, Row* r) const {
        r->x0 = std::max(s.x0, mBox.minX);
        r->x1 = std::min(s.x1, mBox.maxX);
        if (r->x0 > r->x1) return false;
        const int64_t dy = s.y - mBox.minY, dx0 = r->x0 - mBox.minX, width = r->x1 - r->x0;
        for (int i = 0; i < 3; ++i) {
            r->atMinX[i] = mAtCorner[i] + mStepY[i] * dy;
            r->eAtX0[i] = r->atMinX[i] + mBias[i] + mStepX[i] * dx0;
            if (r->eAtX0[i] < 0 && r->eAtX0[i] + mStepX[i] * width < 0) return false;
        }
        return true;
    }

    // The edge functions' steps by a column, as rasterizeReferencePixels takes them.
    const int64_t* stepX() const { return mStepX; }

private:
    const detail::TriangleBox& mBox;
    int64_t mAtCorner[3], mBias[3], mStepX[3], mStepY[3];
};

void checkSpanRequest(const scene::Scene& scene, uint32_t globalTriangle, const Camera& camera,
                      const RenderOptions& options, const RenderTargets& targets,
                      [[maybe_unused]] std::span<const PixelSpan> spans) {
    PLX_CHECK(globalTriangle < scene.triangleCount());
    PLX_CHECK(!options.colorOnly && targets.depth.data && targets.id.data);
    PLX_CHECK(targets.depth.width == camera.width() && targets.depth.height == camera.height());
    PLX_CHECK(targets.id.width == camera.width() && targets.id.height == camera.height());
    PLX_DCHECK(std::is_sorted(spans.begin(), spans.end(),
                              [](const PixelSpan& a, const PixelSpan& b) { return a.y < b.y; }));
}

}  // namespace

int64_t drawTriangleInSpans(const scene::Scene& scene, uint32_t globalTriangle,
                            const Camera& camera, const RenderOptions& options,
                            const RenderTargets& targets, std::span<const PixelSpan> spans) {
    PLX_CHECK(globalTriangle < scene.triangleCount());
    return drawTriangleInSpans(scene, globalTriangle, scene.triangleCorners(globalTriangle), camera,
                               options, targets, spans);
}

int64_t drawTriangleInSpans(const scene::Scene& scene, uint32_t globalTriangle,
                            std::span<const Vec3, 3> corners, const Camera& camera,
                            const RenderOptions& options, const RenderTargets& targets,
                            std::span<const PixelSpan> spans, bool* setUp) {
    checkSpanRequest(scene, globalTriangle, camera, options, targets, spans);
    if (setUp) *setUp = false;
    detail::Viewport vp(camera);
    detail::ShadeContext ctx(options, targets);
    detail::ClippedPieces pieces;
    const int count = detail::clipReferenceCorners(corners.data(), camera, vp, pieces.tris);
    const auto& tris = pieces.tris;
    size_t mesh = 0;
    uint32_t local = 0;
    bool identified = false;
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
        const SpanRows rows(tris[i], box);
        SpanRows::Row row;
        while (first != last && !rows.mayCover(*first, &row)) ++first;
        if (first == last) continue;
        if (!identified) {
            mesh = scene.meshOfTriangle(globalTriangle);
            local = uint32_t(globalTriangle - scene.firstTriangle(mesh));
            identified = true;
        }
        if (setUp) *setUp = true;
        detail::TriangleSetup t;
        detail::setTriangleIdentity(scene, mesh, local, &t);
        detail::isa_scalar::setupTriangleInBox(scene, mesh, local, tris[i], box, ctx, &t);
        for (auto s = first; s != last; ++s) {
            if (s != first && !rows.mayCover(*s, &row)) continue;
            // rowBarycentrics from the exact values: edge 2 (vertex 2 to 0) gives b1, edge 0 b2.
            const float b1Row = float(row.atMinX[2]) * t.invArea;
            const float b2Row = float(row.atMinX[0]) * t.invArea;
            written += detail::rasterizeReferencePixels(t, ctx, targets, s->y, row.x0, row.x1,
                                                        row.eAtX0, rows.stepX(), b1Row, b2Row);
        }
    }
    return written;
}

}  // namespace plx::raster
