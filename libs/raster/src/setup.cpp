// Per-frame constants and structures shared by the tiled renderer and the scalar reference; the
// per-triangle setup and shading are per-ISA kernels (triangle_setup.inl).

#include <algorithm>
#include <cstring>

#include "pipeline.h"

namespace plx::raster::detail {

Viewport::Viewport(const Camera& camera)
    : width(camera.width()),
      height(camera.height()),
      halfWidth(0.5f * float(camera.width())),
      halfHeight(0.5f * float(camera.height())) {
    // Keep snapped pixel coordinates within +-kGuardPixels: |x_ndc| * halfWidth + halfWidth
    // <= kGuardPixels. Images are at most 16384 wide, so the band is at least 3x the viewport.
    guardX = (kGuardPixels - halfWidth) / halfWidth;
    guardY = (kGuardPixels - halfHeight) / halfHeight;
}

ShadeContext::ShadeContext(const RenderOptions& options, const RenderTargets& targets)
    : shading(options.shading),
      lit(options.lit),
      ambient(options.ambient),
      cullBackFaces(options.cullBackFaces),
      collectUnsampled(targets.visibility.unsampledVisible != nullptr),
      colorOnly(options.colorOnly) {
    float len = glm::length(options.lightDir);
    lightDir = len > 0.0f && std::isfinite(len) ? options.lightDir / len : Vec3(0.0f, 1.0f, 0.0f);
}

Rgba8 flatColorOf(const scene::Scene& scene, size_t meshIndex, uint32_t localTri,
                  const ShadeContext& ctx) {
    const scene::Mesh& mesh = scene.meshes[meshIndex];
    const scene::Material& mat = scene.materials[size_t(mesh.materialIndex)];
    const Vec3& normal = scene.faceNormal(scene.firstTriangle(meshIndex) + localTri);
    float light = ctx.lit ? lambert(normal, ctx) : 1.0f;
    return encodeRgb(Vec3(mat.baseColor) * light);
}

void DepthBlocks::resize(int width, int height) {
    const int bx = (width + (1 << kShift) - 1) >> kShift;
    const int by = (height + (1 << kShift) - 1) >> kShift;
    if (bx == blocksX && by == blocksY) return;  // every tile resets its blocks each frame
    blocksX = bx;
    blocksY = by;
    bound.assign(size_t(blocksX) * size_t(blocksY), 0.0f);
    dirty.assign(bound.size(), 1);
}

void DepthBlocks::reset(int x0, int y0, int x1, int y1, bool cleared) {
    for (int by = y0 >> kShift; by <= y1 >> kShift; ++by) {
        size_t row = size_t(by) * size_t(blocksX);
        for (int bx = x0 >> kShift; bx <= x1 >> kShift; ++bx) {
            bound[row + size_t(bx)] = 0.0f;  // the cleared depth, or a bound that always holds
            dirty[row + size_t(bx)] = cleared ? 0 : 1;
        }
    }
}

}  // namespace plx::raster::detail
