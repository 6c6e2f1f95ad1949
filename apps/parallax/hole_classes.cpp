#include "hole_classes.h"

#include <algorithm>
#include <iterator>

namespace plx::cli {

Image<Rgba8> holeClassImage(const Image<Rgba8>& secondEye, const Image<uint8_t>& holeClass) {
    PLX_CHECK(secondEye.width() == holeClass.width() && secondEye.height() == holeClass.height());
    // Indexed by PixelSource; saturated colours stay readable over the dimmed image.
    constexpr Rgba8 kColours[] = {{0, 0, 0, 255},
                                  {255, 220, 0, 255},
                                  {0, 200, 255, 255},
                                  {255, 0, 0, 255},
                                  {255, 0, 255, 255}};
    Image<Rgba8> out(secondEye.width(), secondEye.height());
    for (size_t i = 0; i < out.pixelCount(); ++i) {
        const uint8_t source = holeClass.data()[i];
        const Rgba8 c = secondEye.data()[i];
        out.data()[i] =
            source == uint8_t(stereo::PixelSource::kReprojected) || source >= std::size(kColours)
                ? Rgba8{uint8_t(c.r / 3), uint8_t(c.g / 3), uint8_t(c.b / 3), 255}
                : kColours[source];
    }
    return out;
}

std::vector<uint32_t> trianglesShown(const Image<uint32_t>& ids) {
    std::vector<uint32_t> shown;
    for (size_t i = 0; i < ids.pixelCount(); ++i)
        if (uint32_t id = ids.data()[i]) shown.push_back(id - 1);
    std::sort(shown.begin(), shown.end());
    shown.erase(std::unique(shown.begin(), shown.end()), shown.end());
    return shown;
}

std::vector<uint32_t> drawnSet(const stereo::StereoRenderer& renderer, stereo::Method method,
                               const raster::FrameBuffers& secondEye) {
    if (method == stereo::Method::kReproject) return trianglesShown(secondEye.id);
    return {renderer.lastVisibleSet().begin(), renderer.lastVisibleSet().end()};
}

void renderFullSecondEye(stereo::StereoRenderer& renderer, const scene::Scene& scene,
                         const StereoRig& rig, const raster::RenderOptions& options,
                         raster::FrameBuffers* out) {
    const Camera& camera = rig.second();
    out->resize(camera.width(), camera.height());
    renderer.renderer().render(scene, camera, options, out->targets());
}

}  // namespace plx::cli
