#include <plx/scene/subdivide.h>

#include <unordered_map>

#include <fmt/format.h>

namespace plx::scene {
namespace {

// Index of the vertex halfway along edge (a, b), created on first use. The key orders the two
// ends so that both triangles sharing the edge find the same vertex.
uint32_t midpoint(Mesh* mesh, std::unordered_map<uint64_t, uint32_t>* cache, uint32_t a,
                  uint32_t b) {
    uint64_t key = (uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b));
    auto [it, inserted] = cache->try_emplace(key, uint32_t(mesh->positions.size()));
    if (!inserted) return it->second;
    mesh->positions.push_back(0.5f * (mesh->positions[a] + mesh->positions[b]));
    if (!mesh->normals.empty()) {
        Vec3 n = mesh->normals[a] + mesh->normals[b];
        float length = glm::length(n);
        // Opposite normals on one edge (a crease folded back on itself): keep one end's.
        mesh->normals.push_back(length > 1e-6f ? n / length : mesh->normals[a]);
    }
    if (!mesh->uvs.empty()) mesh->uvs.push_back(0.5f * (mesh->uvs[a] + mesh->uvs[b]));
    return it->second;
}

// One level of 1-to-4 subdivision of one mesh, in place.
void subdivideOnce(Mesh* mesh) {
    std::vector<uint32_t> indices;
    indices.reserve(mesh->indices.size() * 4);
    std::unordered_map<uint64_t, uint32_t> cache;
    cache.reserve(mesh->indices.size());  // about 1.5 edges per triangle
    size_t edges = mesh->indices.size() / 2 + mesh->positions.size();
    mesh->positions.reserve(edges);
    if (!mesh->normals.empty()) mesh->normals.reserve(edges);
    if (!mesh->uvs.empty()) mesh->uvs.reserve(edges);
    for (size_t t = 0; t + 2 < mesh->indices.size(); t += 3) {
        uint32_t a = mesh->indices[t], b = mesh->indices[t + 1], c = mesh->indices[t + 2];
        uint32_t ab = midpoint(mesh, &cache, a, b);
        uint32_t bc = midpoint(mesh, &cache, b, c);
        uint32_t ca = midpoint(mesh, &cache, c, a);
        indices.insert(indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
    }
    mesh->indices = std::move(indices);
}

}  // namespace

Result<Scene> subdivideMidpoint(const Scene& scene, int levels) {
    if (levels < 0 || levels > kMaxSubdivisionLevels) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("subdivision levels {} outside [0, {}]", levels,
                                       kMaxSubdivisionLevels));
    }
    size_t triangles = 0;
    for (const Mesh& mesh : scene.meshes) triangles += mesh.triangleCount();
    size_t result = triangles << (2 * levels);
    if (result > kMaxSubdividedTriangles) {
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("{} triangles subdivided {} times gives {}, over the "
                                       "limit of {}",
                                       triangles, levels, result, kMaxSubdividedTriangles));
    }
    Scene out = scene;
    for (Mesh& mesh : out.meshes) {
        if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("mesh '{}' has {} normals for {} positions", mesh.name,
                                           mesh.normals.size(), mesh.positions.size()));
        }
        if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) {
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("mesh '{}' has {} UVs for {} positions", mesh.name,
                                           mesh.uvs.size(), mesh.positions.size()));
        }
        for (uint32_t index : mesh.indices) {
            if (index >= mesh.positions.size()) {
                return errorStatus(ErrorCode::kInvalidArgument,
                                   fmt::format("mesh '{}' index {} out of range ({} vertices)",
                                               mesh.name, index, mesh.positions.size()));
            }
        }
        for (int level = 0; level < levels; ++level) subdivideOnce(&mesh);
    }
    PLX_RETURN_IF_ERROR(out.finalize());
    return out;
}

}  // namespace plx::scene
