// Two-pass predistortion on the software rasterizer.

#include <plx/display/predistort.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include <plx/core/timing.h>
#include <plx/display/validate.h>

namespace plx::display {
namespace {

// True when every triangle of the pass-2 mesh (positions in the plane z = const) has the same
// orientation or none (zero area): the warp does not fold over, so no two triangles cover the
// same framebuffer sample and the colour-only render gives the depth-tested render's colour. A
// fold (a triangle turned over) would make two layers of the mesh overlap.
bool meshKeepsOrientation(const scene::Mesh& m) {
    int sign = 0;
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
        const Vec3& a = m.positions[m.indices[t]];
        const Vec3& b = m.positions[m.indices[t + 1]];
        const Vec3& c = m.positions[m.indices[t + 2]];
        double area2 = (double(b.x) - a.x) * (double(c.y) - a.y) -
                       (double(b.y) - a.y) * (double(c.x) - a.x);
        int s = (area2 > 0.0) - (area2 < 0.0);
        if (s == 0) continue;
        if (sign == 0) sign = s;
        if (s != sign) return false;
    }
    return true;
}

}  // namespace

scene::Scene fitSceneToContent(const scene::Scene& scene, const Display& display) {
    scene::Scene out = scene;
    const Aabb& b = scene.bounds();
    float radius = std::max(0.5f * b.diagonal(), 1e-6f);
    float scale = float(display.contentRadiusMm) / radius;
    Vec3 centre = b.center();
    Vec3 target(display.contentCenterMm);
    for (auto& m : out.meshes)
        for (auto& p : m.positions) p = target + (p - centre) * scale;
    for (auto& v : out.viewpoints) {  // the same similarity keeps each view on the scene
        v.eyePos = target + (v.eyePos - centre) * scale;
        v.targetPos = target + (v.targetPos - centre) * scale;
    }
    PLX_CHECK(out.finalize().isOk());
    return out;
}

std::vector<DVec3> scenePointsMm(const scene::Scene& scene) {
    std::vector<DVec3> pts;
    for (const auto& m : scene.meshes)
        for (const auto& p : m.positions) pts.emplace_back(p);
    return pts;
}

Status renderViewerImage(raster::Renderer& renderer, const scene::Scene& sceneMm,
                         const ImagePlane& plane, int sizePx, Image<Rgba8>* image,
                         double* milliseconds) {
    CameraDesc desc;
    desc.eyePos = Vec3(plane.eyeMm);
    desc.targetPos = Vec3(plane.eyeMm + plane.forwardDir * plane.distanceMm);
    desc.upDir = Vec3(-glm::normalize(plane.vAxisMm));
    desc.fovYDegrees = float(plane.fovYDegrees);
    float radius = float(0.5 * plane.widthMm);
    desc.nearPlane = std::max(1.0f, float(plane.distanceMm) - 4.0f * radius);
    desc.farPlane = float(plane.distanceMm) + 4.0f * radius;
    desc.width = desc.height = sizePx;
    auto camera = Camera::create(desc);
    if (!camera) return camera.status();
    raster::FrameBuffers fb;
    fb.resize(sizePx, sizePx);
    raster::RenderOptions options;
    options.shading = raster::Shading::kGouraud;
    options.clearColor = {0, 0, 0, 255};
    raster::RenderStats stats = renderer.render(sceneMm, *camera, options, fb.targets());
    if (milliseconds) *milliseconds = stats.milliseconds;
    *image = std::move(fb.color);
    return Status::ok();
}

struct PredistortRenderer::Impl {
    std::unique_ptr<raster::Renderer> renderer;
    scene::Scene scene;  // the warp mesh, textured with the pass-1 image (base level only)
    raster::FrameBuffers fb;
    Image<Rgba8> blank;
    bool colorOnly = true;

    Result<const Image<Rgba8>*> renderFrame(const Display& display, const WarpMesh& mesh,
                                            const Stopwatch& sw, double* milliseconds);
};

PredistortRenderer::PredistortRenderer(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
PredistortRenderer::~PredistortRenderer() = default;

Result<std::unique_ptr<PredistortRenderer>> PredistortRenderer::create(int threads) {
    // 64-pixel tiles, not the renderer's default 128: pass 2 clears only the tiles a mesh draws
    // into, and grid B covers a small part of the frame (BM_PassTwo: no slower than 128).
    auto renderer = raster::Renderer::create({threads, 64});
    if (!renderer) return renderer.status();
    auto impl = std::make_unique<Impl>();
    impl->renderer = std::move(*renderer);
    scene::Texture tex;
    tex.name = "pass1";
    tex.mips.resize(1);
    impl->scene.textures.push_back(std::move(tex));
    impl->scene.materials.push_back({"pass1", {1.0f, 1.0f, 1.0f, 1.0f}, 0});
    impl->scene.meshes.push_back(scene::Mesh{"warp", {}, {}, {}, {}, 0});
    return std::unique_ptr<PredistortRenderer>(new PredistortRenderer(std::move(impl)));
}

raster::Renderer& PredistortRenderer::renderer() { return *mImpl->renderer; }

void PredistortRenderer::setColorOnly(bool enabled) { mImpl->colorOnly = enabled; }

Image<Rgba8>& PredistortRenderer::viewerImage() { return mImpl->scene.textures[0].mips[0]; }

Result<const Image<Rgba8>*> PredistortRenderer::render(const Display& display,
                                                       const WarpMesh& mesh,
                                                       const Image<Rgba8>& image,
                                                       double* milliseconds) {
    Stopwatch sw;
    Image<Rgba8>& base = viewerImage();
    if (&image != &base) {  // the copy reuses the texture's buffer
        if (base.width() != image.width() || base.height() != image.height())
            base.resize(image.width(), image.height());
        std::copy(image.data(), image.data() + image.pixelCount(), base.data());
    }
    return mImpl->renderFrame(display, mesh, sw, milliseconds);
}

Result<const Image<Rgba8>*> PredistortRenderer::render(const Display& display,
                                                       const WarpMesh& mesh,
                                                       double* milliseconds) {
    Stopwatch sw;
    return mImpl->renderFrame(display, mesh, sw, milliseconds);
}

Result<const Image<Rgba8>*> PredistortRenderer::Impl::renderFrame(const Display& display,
                                                                  const WarpMesh& mesh,
                                                                  const Stopwatch& sw,
                                                                  double* milliseconds) {
    int w = display.framebufferWidth, h = display.framebufferHeight;
    if (mesh.triangleCount() == 0 || scene.textures[0].mips[0].empty()) {
        blank.resize(w, h, Rgba8{0, 0, 0, 255});
        if (milliseconds) *milliseconds = sw.elapsedMs();
        return &blank;
    }
    // Camera at the origin looking down -z with a 90 degree vertical field of view: the plane
    // z = -h/2 maps one world unit to one pixel.
    CameraDesc desc;
    desc.eyePos = Vec3(0.0f);
    desc.targetPos = Vec3(0.0f, 0.0f, -1.0f);
    desc.fovYDegrees = 90.0f;
    desc.nearPlane = 0.25f * float(h);
    desc.farPlane = 2.0f * float(h);
    desc.width = w, desc.height = h;
    auto camera = Camera::create(desc);
    if (!camera) return camera.status();
    scene::Mesh& m = scene.meshes[0];
    DVec2 extent = display.displayMax - display.displayMin;
    size_t n = mesh.vertexCount();
    m.positions.resize(n);
    m.uvs.resize(n);
    m.normals.resize(n, Vec3(0.0f, 0.0f, 1.0f));
    for (size_t v = 0; v < n; ++v) {
        DVec2 q = (mesh.displayPos[v] - display.displayMin) / extent;
        m.positions[v] = Vec3(float(q.x * w - 0.5 * w), float(0.5 * h - q.y * h),
                              -0.5f * float(h));
        m.uvs[v] = Vec2(mesh.uvs[v]);
    }
    m.indices.assign(mesh.indices.begin(), mesh.indices.end());
    PLX_RETURN_IF_ERROR(scene.finalize());
    if (fb.color.width() != w || fb.color.height() != h) fb.resize(w, h);
    raster::RenderOptions options;
    options.shading = raster::Shading::kTextured;
    options.lit = false;
    options.clearColor = {0, 0, 0, 255};
    // The mesh lies in one plane, drawn in one layer: unless it folds over, no depth test, no
    // depth or ID target, and only the tiles drawn into last frame or this one are cleared.
    raster::RenderTargets targets = fb.targets();
    if (colorOnly && meshKeepsOrientation(m)) {
        options.colorOnly = true;
        targets = {fb.color.view(), {}, {}, {}};
    }
    // Freshly sized buffers are targets the renderer has no frame of: it clears them whole.
    options.clearDrawnTilesOnly = colorOnly;
    renderer->render(scene, *camera, options, targets);
    if (milliseconds) *milliseconds = sw.elapsedMs();
    return &fb.color;
}

Image<Rgba8> drawMeshOverlay(const Display& display, const WarpMesh& mesh,
                             const Image<Rgba8>* background) {
    int w = display.framebufferWidth, h = display.framebufferHeight;
    Image<Rgba8> out = background ? *background : Image<Rgba8>(w, h, Rgba8{0, 0, 0, 255});
    DVec2 extent = display.displayMax - display.displayMin;
    auto toPx = [&](const DVec2& p) {
        return (p - display.displayMin) / extent * DVec2(out.width(), out.height());
    };
    auto line = [&](DVec2 a, DVec2 b) {
        double len = glm::length(b - a);
        int steps = int(std::min(len, 1e5)) + 1;
        for (int i = 0; i <= steps; ++i) {
            DVec2 p = a + (b - a) * (double(i) / steps);
            int x = int(std::floor(p.x)), y = int(std::floor(p.y));
            if (x >= 0 && y >= 0 && x < out.width() && y < out.height())
                out.at(x, y) = Rgba8{80, 255, 120, 255};
        }
    };
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        const uint32_t* idx = &mesh.indices[3 * t];
        for (int k = 0; k < 3; ++k)
            line(toPx(mesh.displayPos[idx[k]]), toPx(mesh.displayPos[idx[(k + 1) % 3]]));
    }
    return out;
}

}  // namespace plx::display
