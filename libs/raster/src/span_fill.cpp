// Span-restricted scan conversion (span_fill.h) over the reference renderer's setup and rows.

#include <plx/raster/span_fill.h>

#include <algorithm>
#include <bit>
#include <cmath>

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
#include <emmintrin.h>
#endif

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
//
// Most spans a triangle's rows reach are skipped (drawTriangleInSpans), so the exact test runs
// only on the spans that a float test of four spans at once cannot skip: its values are within a
// bound of the exact ones, and it skips a span only where both ends lie outside one edge by more
// than that bound.
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
        setUpFloatTest();
    }

    // Bit k set where span k of the `count` (1 to 4) from `s` may hold a covered sample: the
    // spans mayCover passes, and perhaps a few it does not.
    uint32_t mayCoverFour(const PixelSpan* s, size_t count) const {
        const uint32_t all = (1u << count) - 1u;
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
        const PixelSpan& l = s[count - 1];  // repeated past the end
        const PixelSpan& s1 = count > 1 ? s[1] : l;
        const PixelSpan& s2 = count > 2 ? s[2] : l;
        const __m128 y = _mm_cvtepi32_ps(_mm_setr_epi32(s[0].y, s1.y, s2.y, l.y));
        const __m128 x0 = _mm_max_ps(_mm_cvtepi32_ps(_mm_setr_epi32(s[0].x0, s1.x0, s2.x0, l.x0)),
                                     _mm_set1_ps(float(mBox.minX)));
        const __m128 x1 = _mm_min_ps(_mm_cvtepi32_ps(_mm_setr_epi32(s[0].x1, s1.x1, s2.x1, l.x1)),
                                     _mm_set1_ps(float(mBox.maxX)));
        const __m128 dy = _mm_sub_ps(y, _mm_set1_ps(float(mBox.minY)));
        const __m128 dx0 = _mm_sub_ps(x0, _mm_set1_ps(float(mBox.minX)));
        const __m128 width = _mm_sub_ps(x1, x0);
        __m128 skip = _mm_cmplt_ps(width, _mm_setzero_ps());  // empty once clipped to the box
        for (int i = 0; i < 3; ++i) {
            const __m128 stepX = _mm_set1_ps(mFloatStepX[i]), limit = _mm_set1_ps(mFloatLimit[i]);
            const __m128 e0 = _mm_add_ps(_mm_add_ps(_mm_set1_ps(mFloatAtCorner[i]),
                                                    _mm_mul_ps(_mm_set1_ps(mFloatStepY[i]), dy)),
                                         _mm_mul_ps(stepX, dx0));
            const __m128 e1 = _mm_add_ps(e0, _mm_mul_ps(stepX, width));
            skip = _mm_or_ps(skip, _mm_and_ps(_mm_cmplt_ps(e0, limit), _mm_cmplt_ps(e1, limit)));
        }
        return ~uint32_t(_mm_movemask_ps(skip)) & all;
#else
        (void)s;
        return all;
#endif
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
    // The biased values at the box's first sample and the steps as floats, and per edge the
    // skip limit: minus a bound on the float values' error anywhere in the box. Each of the nine
    // roundings behind a span's second value (three conversions, six operations) errs by at most
    // 2^-24 of a value no larger than `magnitude`; the limit allows 2^-19, over three times their
    // sum.
    void setUpFloatTest() {
        const double width = mBox.maxX - mBox.minX, height = mBox.maxY - mBox.minY;
        for (int i = 0; i < 3; ++i) {
            const double atCorner = double(mAtCorner[i] + mBias[i]);
            mFloatAtCorner[i] = float(atCorner);
            mFloatStepX[i] = float(mStepX[i]);
            mFloatStepY[i] = float(mStepY[i]);
            const double magnitude = std::fabs(atCorner) + std::fabs(double(mStepX[i])) * width +
                                     std::fabs(double(mStepY[i])) * height;
            mFloatLimit[i] = -float(magnitude * 0x1p-19);
        }
    }

    const detail::TriangleBox& mBox;
    int64_t mAtCorner[3], mBias[3], mStepX[3], mStepY[3];
    float mFloatAtCorner[3], mFloatStepX[3], mFloatStepY[3], mFloatLimit[3];
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
        auto last = std::upper_bound(first, spans.end(), box.maxY,
                                     [](int y, const PixelSpan& p) { return y < p.y; });
        // Decided before the setup, which a large triangle passing beside a few hole pixels
        // would otherwise pay for nothing; and per span after it: in the reproject fill most
        // spans of a triangle's rows hold none of its samples.
        const SpanRows rows(tris[i], box);
        const PixelSpan* rowSpans = spans.data() + (first - spans.begin());
        const size_t rowCount = size_t(last - first);
        detail::TriangleSetup t;
        bool ready = false;
        auto setUpOnce = [&] {
            if (!identified) {
                mesh = scene.meshOfTriangle(globalTriangle);
                local = uint32_t(globalTriangle - scene.firstTriangle(mesh));
                identified = true;
            }
            if (setUp) *setUp = true;
            detail::setTriangleIdentity(scene, mesh, local, &t);
            detail::isa_scalar::setupTriangleInBox(scene, mesh, local, tris[i], box, ctx, &t);
            ready = true;
        };
        for (size_t group = 0; group < rowCount; group += 4) {
            uint32_t candidates =
                rows.mayCoverFour(rowSpans + group, std::min<size_t>(4, rowCount - group));
            for (; candidates != 0; candidates &= candidates - 1) {
                const PixelSpan& s = rowSpans[group + size_t(std::countr_zero(candidates))];
                SpanRows::Row row;
                if (!rows.mayCover(s, &row)) continue;
                if (!ready) setUpOnce();
                // rowBarycentrics from the exact values: edge 2 (vertex 2 to 0) gives b1, edge 0
                // b2.
                const float b1Row = float(row.atMinX[2]) * t.invArea;
                const float b2Row = float(row.atMinX[0]) * t.invArea;
                written += detail::rasterizeReferencePixels(t, ctx, targets, s.y, row.x0, row.x1,
                                                            row.eAtX0, rows.stepX(), b1Row, b2Row);
            }
        }
    }
    return written;
}

}  // namespace plx::raster
