// Reader of the database's glTF binary subset (Khronos glTF 2.0, "GLB File Format
// Specification"): header, a JSON chunk, a BIN chunk; float VEC3/VEC2 and uint32 SCALAR
// accessors over buffer views of buffer 0. Anything outside the subset is refused.
#include <plx/stream/glb_reader.h>

#include <algorithm>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "glb_format.h"

namespace plx::stream {
namespace {

using nlohmann::json;

using namespace glb;

Status corrupt(const std::string& what) {
    return errorStatus(ErrorCode::kCorruptData, "glb: " + what);
}

uint32_t readU32(std::span<const uint8_t> b, size_t at) {
    uint32_t v;
    std::memcpy(&v, b.data() + at, 4);
    return v;
}

// An unsigned integer field of an object, or -1 when missing or of another type.
int64_t uintField(const json& j, const char* key) {
    if (!j.is_object() || !j.contains(key) || !j[key].is_number_unsigned()) return -1;
    return int64_t(std::min<uint64_t>(j[key].get<uint64_t>(), uint64_t(1) << 40));
}

// Copies accessor `index` (component type and element width checked) out of the BIN chunk.
template <class T>
Result<std::vector<T>> readAccessor(const json& gltf, std::span<const uint8_t> bin, int64_t index,
                                    int component, const char* type) {
    const json& accessors = gltf.contains("accessors") ? gltf["accessors"] : json();
    if (!accessors.is_array() || index < 0 || size_t(index) >= accessors.size())
        return corrupt(fmt::format("accessor {} missing", index));
    const json& a = accessors[size_t(index)];
    if (uintField(a, "componentType") != component || !a.contains("type") ||
        a["type"] != type)
        return corrupt(fmt::format("accessor {}: not {} of the expected component", index, type));
    int64_t count = uintField(a, "count"), viewIndex = uintField(a, "bufferView");
    const json& views = gltf.contains("bufferViews") ? gltf["bufferViews"] : json();
    if (count < 0 || viewIndex < 0 || !views.is_array() || size_t(viewIndex) >= views.size())
        return corrupt(fmt::format("accessor {}: count or buffer view missing", index));
    const json& v = views[size_t(viewIndex)];
    int64_t offset = uintField(v, "byteOffset"), length = uintField(v, "byteLength");
    if (offset < 0) offset = 0;
    uint64_t need = uint64_t(count) * sizeof(T);
    if (length < 0 || uint64_t(length) < need || uint64_t(offset) + uint64_t(length) > bin.size())
        return corrupt(fmt::format("accessor {}: outside the binary chunk", index));
    std::vector<T> out(static_cast<size_t>(count));
    if (need) std::memcpy(out.data(), bin.data() + offset, size_t(need));
    return out;
}

Result<GlbPrimitive> readPrimitive(const json& gltf, std::span<const uint8_t> bin, const json& p) {
    if (!p.is_object() || !p.contains("attributes") || !p["attributes"].is_object())
        return corrupt("primitive without attributes");
    const json& attr = p["attributes"];
    GlbPrimitive out;
    auto pos = readAccessor<Vec3>(gltf, bin, uintField(attr, "POSITION"), kFloat, "VEC3");
    if (!pos) return pos.status();
    out.positions = std::move(pos).value();
    if (attr.contains("TEXCOORD_0")) {
        auto uv = readAccessor<Vec2>(gltf, bin, uintField(attr, "TEXCOORD_0"), kFloat, "VEC2");
        if (!uv) return uv.status();
        if (uv->size() != out.positions.size()) return corrupt("TEXCOORD_0 count differs");
        out.uvs = std::move(uv).value();
    }
    auto idx = readAccessor<uint32_t>(gltf, bin, uintField(p, "indices"), kUnsignedInt, "SCALAR");
    if (!idx) return idx.status();
    out.indices = std::move(idx).value();
    if (out.indices.size() % 3 != 0) return corrupt("index count not a multiple of 3");
    for (uint32_t i : out.indices)
        if (i >= out.positions.size()) return corrupt("index beyond the vertex count");
    int64_t material = uintField(p, "material");
    if (material >= 0) {
        const json& mats = gltf.contains("materials") ? gltf["materials"] : json();
        if (!mats.is_array() || size_t(material) >= mats.size())
            return corrupt("material index out of range");
        const json& m = mats[size_t(material)];
        if (m.is_object() && m.contains("pbrMetallicRoughness") &&
            m["pbrMetallicRoughness"].is_object() &&
            m["pbrMetallicRoughness"].contains("baseColorFactor")) {
            const json& f = m["pbrMetallicRoughness"]["baseColorFactor"];
            if (!f.is_array() || f.size() != 4) return corrupt("baseColorFactor not 4 numbers");
            for (int i = 0; i < 4; ++i) {
                if (!f[size_t(i)].is_number()) return corrupt("baseColorFactor not 4 numbers");
                out.baseColor[i] = std::clamp(f[size_t(i)].get<float>(), 0.0f, 1.0f);
            }
        }
        if (m.is_object() && m.contains("extras") && m["extras"].is_object() &&
            m["extras"].contains("ptm")) {
            if (!m["extras"]["ptm"].is_string()) return corrupt("extras.ptm not a string");
            out.ptmUrl = m["extras"]["ptm"].get<std::string>();
        }
    }
    return out;
}

}  // namespace

Result<std::vector<GlbPrimitive>> parseGlb(std::span<const uint8_t> bytes) {
    if (bytes.size() < 20) return corrupt("shorter than the header and a chunk header");
    if (readU32(bytes, 0) != kGlbMagic) return corrupt("bad magic");
    if (readU32(bytes, 4) != 2) return corrupt("version is not 2");
    if (readU32(bytes, 8) != bytes.size()) return corrupt("length differs from the file size");
    uint32_t jsonLength = readU32(bytes, 12);
    if (readU32(bytes, 16) != kChunkJson || jsonLength > bytes.size() - 20)
        return corrupt("JSON chunk missing or longer than the file");
    std::span<const uint8_t> bin;
    size_t at = 20 + size_t(jsonLength);
    if (at < bytes.size()) {
        if (bytes.size() - at < 8) return corrupt("truncated BIN chunk header");
        uint32_t binLength = readU32(bytes, at);
        if (readU32(bytes, at + 4) != kChunkBin || binLength > bytes.size() - at - 8)
            return corrupt("BIN chunk missing or longer than the file");
        bin = bytes.subspan(at + 8, binLength);
    }
    json gltf = json::parse(bytes.begin() + 20, bytes.begin() + long(at), nullptr, false);
    if (gltf.is_discarded() || !gltf.is_object()) return corrupt("JSON chunk does not parse");
    std::vector<GlbPrimitive> out;
    if (!gltf.contains("meshes")) return out;  // a cell of empty space
    const json& meshes = gltf["meshes"];
    if (!meshes.is_array() || meshes.size() != 1 || !meshes[0].is_object() ||
        !meshes[0].contains("primitives") || !meshes[0]["primitives"].is_array())
        return corrupt("not one mesh with a primitives array");
    for (const json& p : meshes[0]["primitives"]) {
        auto prim = readPrimitive(gltf, bin, p);
        if (!prim) return prim.status();
        out.push_back(std::move(prim).value());
    }
    return out;
}

}  // namespace plx::stream
