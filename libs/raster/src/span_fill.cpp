// Span-restricted scan conversion (span_fill.h) over the reference renderer's setup and rows.

#include <plx/raster/span_fill.h>

#include "pipeline.h"

namespace plx::raster {

int64_t drawTriangleInSpans(const scene::Scene& scene, uint32_t globalTriangle,
                            const Camera& camera, const RenderOptions& options,
                            const RenderTargets& targets, std::span<const PixelSpan> spans) {
    PLX_CHECK(globalTriangle < scene.triangleCount());
    PLX_CHECK(!options.colorOnly && targets.depth.data && targets.id.data);
    PLX_CHECK(targets.depth.width == camera.width() && targets.depth.height == camera.height());
    PLX_CHECK(targets.id.width == camera.width() && targets.id.height == camera.height());
    detail::Viewport vp(camera);
    detail::ShadeContext ctx(options, targets);
    detail::TriangleSetup setups[detail::kMaxClippedTriangles];
    int count = detail::setupReferenceTriangles(scene, globalTriangle, camera, vp, ctx, setups);
    int64_t written = 0;
    for (int i = 0; i < count; ++i) {
        const detail::TriangleSetup& t = setups[i];
        for (const PixelSpan& s : spans)
            written += detail::rasterizeReferenceRow(t, ctx, targets, s.y, s.x0, s.x1);
    }
    return written;
}

}  // namespace plx::raster
