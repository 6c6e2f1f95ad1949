// The scalar reference renderer: one triangle after another over the whole image, each sample
// tested by its three integer edge functions, stepped exactly along the row. No tiles, no
// threads, no spans. Tests check that the tiled renderer produces exactly the same targets.

#include "pipeline.h"

namespace plx::raster {
namespace {

using namespace detail;

int64_t edgeValue(const TriangleSetup& t, int i, int64_t px, int64_t py) {
    int j = (i + 1) % 3;
    return int64_t(t.x[j] - t.x[i]) * (py - t.y[i]) - int64_t(t.y[j] - t.y[i]) * (px - t.x[i]);
}

// The reference's row y of the setup's box: the edge functions at the sample of (minX, y) and the
// row's barycentrics, then the pixel loop every path shares. Takes the scalar path's setup and
// shading (isa_scalar) whatever path is active.
void rasterizeReferenceRow(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                           int y) {
    float b1Row, b2Row;
    rowBarycentrics(t, y, &b1Row, &b2Row);
    const int64_t px = int64_t(t.minX) * kSubPixelScale + kSubPixelScale / 2;
    const int64_t py = int64_t(y) * kSubPixelScale + kSubPixelScale / 2;
    int64_t e[3], step[3];
    for (int i = 0; i < 3; ++i) {
        e[i] = edgeValue(t, i, px, py) + t.edgeBias[i];
        step[i] = -int64_t(t.y[(i + 1) % 3] - t.y[i]) * kSubPixelScale;
    }
    rasterizeReferencePixels(t, ctx, rt, y, t.minX, t.maxX, e, step, b1Row, b2Row);
}

void rasterizeReference(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt) {
    for (int y = t.minY; y <= t.maxY; ++y) rasterizeReferenceRow(t, ctx, rt, y);
}

}  // namespace

namespace detail {

int clipReferenceTriangle(const scene::Scene& scene, uint32_t globalTri, const Camera& camera,
                          const Viewport& vp, RasterVertex out[kMaxClippedTriangles][3],
                          size_t* meshIndex, uint32_t* localTri) {
    size_t m = scene.meshOfTriangle(globalTri);
    uint32_t local = uint32_t(globalTri - scene.firstTriangle(m));
    *meshIndex = m;
    *localTri = local;
    return clipReferenceCorners(scene.triangleCorners(globalTri).data(), camera, vp, out);
}

int clipReferenceCorners(const Vec3 corners[3], const Camera& camera, const Viewport& vp,
                         RasterVertex out[kMaxClippedTriangles][3]) {
    Vec4 clip[3];
    uint32_t codes[3];
    for (int k = 0; k < 3; ++k) {
        clip[k] = camera.clipFromWorld() * Vec4(corners[k], 1.0f);
        codes[k] = outcode(clip[k], vp);
    }
    if (codes[0] & codes[1] & codes[2] & kOutFrustum) return 0;
    if ((codes[0] | codes[1] | codes[2]) & kOutNeedsClip) return clipTriangle(clip, vp, out);
    for (int k = 0; k < 3; ++k) out[0][k] = snapVertex(clip[k], vp, Vec3(k == 0, k == 1, k == 2));
    return 1;
}

}  // namespace detail

namespace {

void drawTriangle(const scene::Scene& scene, uint32_t globalTri, const Camera& camera,
                  const Viewport& vp, const ShadeContext& ctx, const RenderTargets& rt) {
    RasterVertex tris[kMaxClippedTriangles][3];
    size_t mesh;
    uint32_t local;
    int count = clipReferenceTriangle(scene, globalTri, camera, vp, tris, &mesh, &local);
    for (int i = 0; i < count; ++i) {
        TriangleSetup setup;
        if (isa_scalar::setupTriangle(scene, mesh, local, tris[i], vp, ctx, &setup))
            rasterizeReference(setup, ctx, rt);
    }
}

}  // namespace

void renderReference(const scene::Scene& scene, const Camera& camera, const RenderOptions& options,
                     const RenderTargets& rt, std::span<const uint32_t>* subset) {
    checkRenderRequestOrDie(camera, options, rt);
    if (!options.colorOnly && (!rt.depth.data || !rt.id.data)) {
        // The planes the caller leaves out (see RenderTargets) live in scratch images here.
        Image<float> depth(rt.depth.data ? 0 : camera.width(), rt.depth.data ? 0 : camera.height());
        Image<uint32_t> id(rt.id.data ? 0 : camera.width(), rt.id.data ? 0 : camera.height());
        RenderTargets complete = rt;
        if (!rt.depth.data) complete.depth = depth.view();
        if (!rt.id.data) complete.id = id.view();
        renderReference(scene, camera, options, complete, subset);
        return;
    }
    Viewport vp(camera);
    ShadeContext ctx(options, rt);
    if (options.clearTargets) {
        if (!options.colorOnly) {
            rt.depth.fill(0.0f);
            rt.id.fill(0u);
        }
        if (rt.color.data) rt.color.fill(options.clearColor);
        if (rt.visibility.id2.data) {
            rt.visibility.depth2.fill(0.0f);
            rt.visibility.id2.fill(0u);
        }
    }
    if (subset) {
        for (uint32_t tri : *subset) {
            PLX_CHECK(tri < scene.triangleCount());
            drawTriangle(scene, tri, camera, vp, ctx, rt);
        }
    } else {
        for (uint32_t tri = 0; tri < scene.triangleCount(); ++tri)
            drawTriangle(scene, tri, camera, vp, ctx, rt);
    }
}

}  // namespace plx::raster
