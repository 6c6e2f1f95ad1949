#pragma once
// A small glTF 2.0 binary (.glb) writer for one cell's polygons (docs/stream-format.md,
// "Geometry"): only what the database needs, so no exporter dependency.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <plx/scene/scene.h>

namespace plx::stream {

// The GLB of the listed global triangles (ascending): one primitive per material, vertices
// de-duplicated per primitive; a textured material names its PTM file by
// `textureUrlOf(textureIndex)` in its extras.
std::vector<uint8_t> writeCellGlb(const scene::Scene& scene, const std::vector<uint32_t>& triangles,
                                  const std::function<std::string(int)>& textureUrlOf);

}  // namespace plx::stream
