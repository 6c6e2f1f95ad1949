#pragma once
// What the CLI shows of the reproject method (Fu, Bao, Peng): the second eye with each pixel
// coloured by how it was produced (stereo::PixelSource), the polygons an eye shows, and the full
// method's second eye that compareSecondEye measures it against.

#include <cstdint>
#include <vector>

#include <plx/stereo/stereo.h>

namespace plx::cli {

// The colours of holeClassImage, for legends in --help, the demo and the docs.
inline constexpr const char* kHoleClassLegend =
    "reprojected pixels dimmed; expansion holes yellow, disocclusion holes cyan, disocclusion "
    "holes no polygon covers red, reprojected pixels hidden by what the first eye could not see "
    "magenta";

// The second eye dimmed to a third where its pixels were reprojected, and the holes painted in
// their class's colour (kHoleClassLegend). Precondition: both images have the same size.
Image<Rgba8> holeClassImage(const Image<Rgba8>& secondEye, const Image<uint8_t>& holeClass);

// The distinct triangle indices (ID - 1) an ID target shows, ascending.
std::vector<uint32_t> trianglesShown(const Image<uint32_t>& ids);

// The set compareSecondEye takes as `drawn` for the frame `renderer` rendered last: the visible
// set of the pbuffer method; the reproject method draws from no set, so the triangles its second
// eye shows (reprojected or filled): a polygon of the full render it lacks is then missed.
std::vector<uint32_t> drawnSet(const stereo::StereoRenderer& renderer, stereo::Method method,
                               const raster::FrameBuffers& secondEye);

// The full method's second eye, with depth and IDs: the whole scene drawn from rig.second() by
// the stereo renderer's own raster renderer (its full method's second half, without the first).
void renderFullSecondEye(stereo::StereoRenderer& renderer, const scene::Scene& scene,
                         const StereoRig& rig, const raster::RenderOptions& options,
                         raster::FrameBuffers* out);

}  // namespace plx::cli
