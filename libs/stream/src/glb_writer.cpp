// glTF 2.0 binary writer (Khronos glTF 2.0 specification, "GLB File Format Specification").

#include "glb_writer.h"
#include "glb_format.h"

#include <cstring>
#include <map>
#include <unordered_map>

#include <nlohmann/json.hpp>

namespace plx::stream {
namespace {

using nlohmann::json;

using namespace glb;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// One primitive under construction: the vertices it uses, each once.
struct Primitive {
    std::vector<Vec3> positions, normals;
    std::vector<Vec2> uvs;
    std::vector<uint32_t> indices;
    bool hasUvs = false;
    std::unordered_map<uint64_t, uint32_t> remap;  // (mesh << 32 | vertex) -> primitive vertex
};

void appendBytes(std::vector<uint8_t>* out, const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    out->insert(out->end(), p, p + n);
}

void appendU32(std::vector<uint8_t>* out, uint32_t v) {
    appendBytes(out, &v, 4);
}

// Appends an array to the binary chunk as its own buffer view and accessor; returns the accessor.
template <class T>
int addAccessor(json& gltf, std::vector<uint8_t>* bin, const std::vector<T>& data, int component,
                const char* type, int target) {
    while (bin->size() % 4 != 0) bin->push_back(0);
    const size_t offset = bin->size();
    appendBytes(bin, data.data(), data.size() * sizeof(T));
    gltf["bufferViews"].push_back({{"buffer", 0},
                                   {"byteOffset", offset},
                                   {"byteLength", data.size() * sizeof(T)},
                                   {"target", target}});
    json accessor = {{"bufferView", gltf["bufferViews"].size() - 1},
                     {"componentType", component},
                     {"count", data.size()},
                     {"type", type}};
    gltf["accessors"].push_back(accessor);
    return int(gltf["accessors"].size() - 1);
}

// Collects the triangles into one primitive per material, in material order.
std::map<int, Primitive> buildPrimitives(const scene::Scene& scene,
                                         const std::vector<uint32_t>& triangles) {
    std::map<int, Primitive> prims;
    for (uint32_t tri : triangles) {
        const size_t m = scene.meshOfTriangle(tri);
        const scene::Mesh& mesh = scene.meshes[m];
        const size_t t = tri - scene.firstTriangle(m);
        Primitive& p = prims[mesh.materialIndex];
        p.hasUvs = p.hasUvs || !mesh.uvs.empty();
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = mesh.indices[3 * t + size_t(k)];
            auto [it, inserted] =
                p.remap.try_emplace(uint64_t(m) << 32 | v, uint32_t(p.positions.size()));
            if (inserted) {
                p.positions.push_back(mesh.positions[v]);
                p.normals.push_back(mesh.normals[v]);
                // Meshes without UVs in a textured material's primitive get (0, 0).
                p.uvs.push_back(mesh.uvs.empty() ? Vec2(0.0f) : mesh.uvs[v]);
            }
            p.indices.push_back(it->second);
        }
    }
    return prims;
}

}  // namespace

std::vector<uint8_t> writeCellGlb(const scene::Scene& scene, const std::vector<uint32_t>& triangles,
                                  const std::function<std::string(int)>& textureUrlOf) {
    json gltf = {{"asset", {{"version", "2.0"}, {"generator", "parallax stream build"}}},
                 {"scene", 0},
                 {"scenes", {{{"nodes", json::array()}}}},
                 {"bufferViews", json::array()},
                 {"accessors", json::array()},
                 {"materials", json::array()}};
    std::vector<uint8_t> bin;
    json primitives = json::array();
    for (auto& [materialIndex, p] : buildPrimitives(scene, triangles)) {
        Aabb box;
        for (const Vec3& v : p.positions) box.extend(v);
        json attributes;
        attributes["POSITION"] = addAccessor(gltf, &bin, p.positions, kFloat, "VEC3", kArrayBuffer);
        gltf["accessors"].back()["min"] = {box.lo.x, box.lo.y, box.lo.z};
        gltf["accessors"].back()["max"] = {box.hi.x, box.hi.y, box.hi.z};
        attributes["NORMAL"] = addAccessor(gltf, &bin, p.normals, kFloat, "VEC3", kArrayBuffer);
        if (p.hasUvs)
            attributes["TEXCOORD_0"] = addAccessor(gltf, &bin, p.uvs, kFloat, "VEC2", kArrayBuffer);
        int indices =
            addAccessor(gltf, &bin, p.indices, kUnsignedInt, "SCALAR", kElementArrayBuffer);
        const scene::Material& mat = scene.materials[size_t(materialIndex)];
        json material = {{"name", mat.name},
                         {"pbrMetallicRoughness",
                          {{"baseColorFactor",
                            {mat.baseColor.r, mat.baseColor.g, mat.baseColor.b, mat.baseColor.a}},
                           {"metallicFactor", 0.0},
                           {"roughnessFactor", 1.0}}}};
        if (mat.baseColorTexture >= 0)
            material["extras"] = {{"ptm", textureUrlOf(mat.baseColorTexture)}};
        gltf["materials"].push_back(material);
        primitives.push_back({{"attributes", attributes},
                              {"indices", indices},
                              {"material", gltf["materials"].size() - 1},
                              {"mode", 4}});
    }
    if (!primitives.empty()) {
        gltf["meshes"] = {{{"primitives", primitives}}};
        gltf["nodes"] = {{{"mesh", 0}}};
        gltf["scenes"][0]["nodes"].push_back(0);
    }
    while (bin.size() % 4 != 0) bin.push_back(0);
    if (!bin.empty()) gltf["buffers"] = {{{"byteLength", bin.size()}}};
    if (gltf["materials"].empty()) gltf.erase("materials");
    if (gltf["accessors"].empty()) gltf.erase("accessors"), gltf.erase("bufferViews");
    std::string text = gltf.dump();
    while (text.size() % 4 != 0) text.push_back(' ');
    std::vector<uint8_t> out;
    const uint32_t total =
        12 + 8 + uint32_t(text.size()) + (bin.empty() ? 0 : 8 + uint32_t(bin.size()));
    appendU32(&out, kGlbMagic);
    appendU32(&out, 2);
    appendU32(&out, total);
    appendU32(&out, uint32_t(text.size()));
    appendU32(&out, kChunkJson);
    appendBytes(&out, text.data(), text.size());
    if (!bin.empty()) {
        appendU32(&out, uint32_t(bin.size()));
        appendU32(&out, kChunkBin);
        appendBytes(&out, bin.data(), bin.size());
    }
    return out;
}

}  // namespace plx::stream
