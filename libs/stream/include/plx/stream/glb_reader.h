#pragma once
// A reader of the database's own glTF binary subset (docs/stream-format.md, "Geometry"): the
// bytes are untrusted. It checks the GLB header, chunk lengths against the file size, every
// accessor's range against the buffer and every index against its primitive's vertex count.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <plx/core/core.h>

namespace plx::stream {

struct GlbPrimitive {
    std::vector<Vec3> positions;
    std::vector<Vec2> uvs;          // empty, or one per position
    std::vector<uint32_t> indices;  // triangles; each < positions.size()
    std::string ptmUrl;             // the material's PTM (extras.ptm), empty when untextured
    Vec4 baseColor{1.0f};           // the material's baseColorFactor (linear RGBA)
};

// Parses a cell's .glb. Errors are one line naming the part that is wrong.
Result<std::vector<GlbPrimitive>> parseGlb(std::span<const uint8_t> bytes);

}  // namespace plx::stream
