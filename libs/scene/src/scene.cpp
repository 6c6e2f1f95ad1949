#include <algorithm>
#include <charconv>

#include <fmt/format.h>

#include <plx/scene/scene.h>

namespace plx::scene {
namespace {

// Viewpoints and rooms become cameras (findViewpoint, the streaming tour): each point finite
// and within a camera's range, each room a box.
Status checkViewpointsAndRooms(const Scene& scene) {
    auto framable = [](const Vec3& v) { return isFinite(v) && !beyondCameraRange(v); };
    for (const Viewpoint& v : scene.viewpoints)
        if (!framable(v.eyePos) || !framable(v.targetPos) || !framable(v.upDir))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("viewpoint '{}' has a non-finite or too distant eye, "
                                           "target or up vector",
                                           printable(v.name)));
    for (size_t r = 0; r < scene.rooms.size(); ++r) {
        const Aabb& box = scene.rooms[r];
        if (!framable(box.lo) || !framable(box.hi) || box.isEmpty())
            return errorStatus(
                ErrorCode::kCorruptData,
                fmt::format("room {} is not a finite box within +-{:g}", r, kMaxCameraCoordinate));
    }
    return Status::ok();
}

Status checkMesh(const Scene& scene, size_t m) {
    const Mesh& mesh = scene.meshes[m];
    auto where = [&] { return fmt::format("mesh {} ('{}')", m, printable(mesh.name)); };
    if (mesh.indices.size() % 3 != 0)
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("{}: index count {} is not a multiple of 3", where(),
                                       mesh.indices.size()));
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
        return errorStatus(ErrorCode::kCorruptData, where() + ": normal count differs from "
                                                              "vertex count");
    if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size())
        return errorStatus(ErrorCode::kCorruptData, where() + ": UV count differs from vertex "
                                                              "count");
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
        const Vec3& p = mesh.positions[v];
        if (!isFinite(p))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("{}: vertex {} has a non-finite position", where(), v));
        if (beyondCameraRange(p))
            return errorStatus(
                ErrorCode::kOutOfRange,
                fmt::format("{}: vertex {} at ({:g}, {:g}, {:g}) lies beyond +-{:g}, "
                            "the farthest a camera can frame",
                            where(), v, p.x, p.y, p.z, kMaxCameraCoordinate));
    }
    for (size_t v = 0; v < mesh.uvs.size(); ++v)
        if (!std::isfinite(mesh.uvs[v].x) || !std::isfinite(mesh.uvs[v].y))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("{}: vertex {} has a non-finite UV", where(), v));
    for (uint32_t i : mesh.indices)
        if (i >= mesh.positions.size())
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("{}: index {} out of range ({} vertices)", where(), i,
                                           mesh.positions.size()));
    if (mesh.materialIndex < 0 || size_t(mesh.materialIndex) >= scene.materials.size())
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("{}: material {} does not exist", where(),
                                       mesh.materialIndex));
    return Status::ok();
}

// cross(p1 - p0, p2 - p0) of triangle t: its plane's normal, twice its area long.
Vec3 faceCross(const Mesh& mesh, size_t t) {
    const uint32_t* idx = &mesh.indices[3 * t];
    return glm::cross(mesh.positions[idx[1]] - mesh.positions[idx[0]],
                      mesh.positions[idx[2]] - mesh.positions[idx[0]]);
}

// Area-weighted face normals accumulated per vertex.
void computeNormals(Mesh* mesh) {
    mesh->normals.assign(mesh->positions.size(), Vec3(0.0f));
    for (size_t t = 0; t < mesh->triangleCount(); ++t) {
        Vec3 n = faceCross(*mesh, t);
        for (int k = 0; k < 3; ++k) mesh->normals[mesh->indices[3 * t + k]] += n;
    }
}

// Appends the unit face normal of every triangle of the mesh (flat shading's normal).
void appendFaceNormals(const Mesh& mesh, std::vector<Vec3>* out) {
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        Vec3 n = faceCross(mesh, t);
        float len = glm::length(n);
        out->push_back(len > 0.0f ? n / len : Vec3(0.0f, 1.0f, 0.0f));
    }
}

void normaliseNormals(Mesh* mesh) {
    for (Vec3& n : mesh->normals) {
        float len = glm::length(n);
        n = (std::isfinite(len) && len > 1e-20f) ? n / len : Vec3(0.0f, 1.0f, 0.0f);
    }
}

}  // namespace

Status Scene::finalize() {
    if (materials.empty()) materials.push_back(Material{"default", {0.8f, 0.8f, 0.8f, 1.0f}, -1});
    for (size_t i = 0; i < materials.size(); ++i) {
        int t = materials[i].baseColorTexture;
        if (t >= int(textures.size()) || t < -1)
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("material {} refers to missing texture {}", i, t));
        const Vec4& color = materials[i].baseColor;
        if (!isFinite(Vec3(color)) || !std::isfinite(color.w))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("material {} has a non-finite colour", i));
    }
    PLX_RETURN_IF_ERROR(checkViewpointsAndRooms(*this));
    for (const Texture& tex : textures)
        if (tex.mips.empty() || tex.mips[0].empty())
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("texture '{}' has no texels", printable(tex.name)));
    mFirstTriangle.assign(meshes.size(), 0);
    mTriangleCount = 0;
    mBounds = Aabb{};
    mFaceNormals.clear();
    for (size_t m = 0; m < meshes.size(); ++m) {
        PLX_RETURN_IF_ERROR(checkMesh(*this, m));
        Mesh& mesh = meshes[m];
        if (mesh.normals.empty()) computeNormals(&mesh);
        normaliseNormals(&mesh);
        mFirstTriangle[m] = mTriangleCount;
        mTriangleCount += mesh.triangleCount();
        appendFaceNormals(mesh, &mFaceNormals);
        for (uint32_t i : mesh.indices) mBounds.extend(mesh.positions[i]);
    }
    if (mTriangleCount == 0)
        return errorStatus(ErrorCode::kCorruptData, "scene has no triangles");
    if (mTriangleCount >= size_t(UINT32_MAX))
        return errorStatus(ErrorCode::kOutOfRange, "scene has more than 2^32-1 triangles");
    return Status::ok();
}

size_t Scene::meshOfTriangle(uint32_t globalTriangle) const {
    PLX_DCHECK(globalTriangle < mTriangleCount);
    auto it = std::upper_bound(mFirstTriangle.begin(), mFirstTriangle.end(), size_t(globalTriangle));
    return size_t(it - mFirstTriangle.begin()) - 1;
}

std::array<Vec3, 3> Scene::triangleCorners(uint32_t globalTriangle) const {
    const size_t m = meshOfTriangle(globalTriangle);
    const Mesh& mesh = meshes[m];
    const size_t first = 3 * (globalTriangle - mFirstTriangle[m]);
    return {mesh.positions[mesh.indices[first]], mesh.positions[mesh.indices[first + 1]],
            mesh.positions[mesh.indices[first + 2]]};
}

SceneStats Scene::stats() const {
    SceneStats s;
    s.meshes = meshes.size();
    for (const Mesh& m : meshes) s.vertices += m.vertexCount();
    s.triangles = mTriangleCount;
    s.materials = materials.size();
    s.textures = textures.size();
    for (const Texture& t : textures)
        for (const auto& mip : t.mips) s.textureBytes += mip.pixelCount() * sizeof(Rgba8);
    s.degenerateTrianglesDropped = degenerateTrianglesDropped;
    s.texturesMissing = texturesMissing;
    s.bounds = mBounds;
    return s;
}

void buildMipChain(Texture* texture) {
    PLX_CHECK(texture->mips.size() == 1);
    const float* decode = srgbDecodeTable();
    while (texture->mips.back().width() > 1 || texture->mips.back().height() > 1) {
        const Image<Rgba8>& src = texture->mips.back();
        int w = std::max(1, (src.width() + 1) / 2), h = std::max(1, (src.height() + 1) / 2);
        Image<Rgba8> dst(w, h);
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                Vec4 sum(0.0f);
                int n = 0;
                for (int dy = 0; dy < 2; ++dy) {
                    for (int dx = 0; dx < 2; ++dx) {
                        int sx = 2 * x + dx, sy = 2 * y + dy;
                        if (sx >= src.width() || sy >= src.height()) continue;
                        Rgba8 c = src.at(sx, sy);
                        sum += Vec4(decode[c.r], decode[c.g], decode[c.b], float(c.a));
                        ++n;
                    }
                }
                sum /= float(n);
                dst.at(x, y) = encodeRgb(Vec3(sum), uint8_t(std::lround(sum.a)));
            }
        }
        texture->mips.push_back(std::move(dst));
    }
}

Viewpoint framingViewpoint(const Aabb& bounds, float fovYDegrees) {
    Viewpoint v;
    v.name = "framing";
    v.fovYDegrees = fovYDegrees;
    Vec3 c = bounds.isEmpty() ? Vec3(0.0f) : bounds.center();
    float radius = std::max(0.5f * bounds.diagonal(), 1e-3f);
    float dist = radius / std::sin(radians(fovYDegrees) * 0.5f);
    Vec3 dir = glm::normalize(Vec3(0.0f, 0.35f, 1.0f));
    v.eyePos = c + dir * dist;
    v.targetPos = c;
    return v;
}

void clipPlanesFor(const Aabb& bounds, const Vec3& eyePos, float* nearPlane, float* farPlane) {
    float farthest = 0.0f;
    for (int i = 0; i < 8; ++i) {
        Vec3 corner((i & 1) ? bounds.hi.x : bounds.lo.x, (i & 2) ? bounds.hi.y : bounds.lo.y,
                    (i & 4) ? bounds.hi.z : bounds.lo.z);
        farthest = std::max(farthest, glm::length(corner - eyePos));
    }
    *farPlane = std::max(farthest * 1.01f, 1e-2f);
    // A near plane at 1/20000 of the far distance keeps depth precision (1/w is stored in float,
    // so precision is ample) while letting walkthrough cameras get close to walls.
    *nearPlane = std::max(*farPlane / 20000.0f, 1e-4f);
}

Result<Camera> cameraAt(const Scene& scene, const Viewpoint& viewpoint, int width, int height) {
    CameraDesc d;
    d.eyePos = viewpoint.eyePos;
    d.targetPos = viewpoint.targetPos;
    d.upDir = viewpoint.upDir;
    d.fovYDegrees = viewpoint.fovYDegrees;
    d.width = width;
    d.height = height;
    clipPlanesFor(scene.bounds(), viewpoint.eyePos, &d.nearPlane, &d.farPlane);
    return Camera::create(d);
}

Viewpoint defaultViewpoint(const Scene& scene) {
    return scene.viewpoints.empty() ? framingViewpoint(scene.bounds()) : scene.viewpoints.front();
}

Result<Viewpoint> findViewpoint(const Scene& scene, const std::string& which) {
    if (which.empty()) return defaultViewpoint(scene);
    for (const auto& v : scene.viewpoints)
        if (v.name == which) return v;
    size_t index = 0;
    auto [end, ec] = std::from_chars(which.data(), which.data() + which.size(), index);
    if (ec == std::errc() && end == which.data() + which.size() && index < scene.viewpoints.size())
        return scene.viewpoints[index];
    std::string names;
    for (const auto& v : scene.viewpoints) names += (names.empty() ? "" : ", ") + v.name;
    return errorStatus(ErrorCode::kNotFound,
                       fmt::format("no viewpoint '{}' in the scene (it has: {})", which,
                                   names.empty() ? "none" : names));
}

}  // namespace plx::scene
