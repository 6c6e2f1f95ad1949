#pragma once
// Scene: triangle meshes with per-vertex normals and UVs, materials, decoded textures with mip
// chains, and named viewpoints. Everything the renderers draw comes through this type.
//
// Triangle numbering: triangles are numbered scene-globally in mesh order, mesh m's local
// triangle t having global index firstTriangle(m) + t. The polygon-ID target stores that index+1
// (see the Conventions block in <plx/core/core.h>).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <plx/core/core.h>

namespace plx::scene {

// A decoded texture: RGBA8 texels holding sRGB-encoded colour, with a full mip chain down to 1x1.
struct Texture {
    std::string name;
    // mips[0] is the base level; mips[k] is ceil-halved from mips[k-1], last one 1x1.
    std::vector<Image<Rgba8>> mips;

    int width() const { return mips.empty() ? 0 : mips[0].width(); }
    int height() const { return mips.empty() ? 0 : mips[0].height(); }
};

// Builds mips[1..] from mips[0] with a 2x2 box filter in linear light (odd sizes: the last
// row/column is averaged with fewer texels). Precondition (checked, abort): mips has exactly one
// level.
void buildMipChain(Texture* texture);

struct Material {
    std::string name;
    Vec4 baseColor{0.8f, 0.8f, 0.8f, 1.0f};  // linear RGBA factor
    int baseColorTexture = -1;               // index into Scene::textures, -1 for none
};

struct Mesh {
    std::string name;
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;     // unit length, one per position
    // One per position, or empty when the mesh has none. (0,0) is the top-left texel of the
    // texture's mips[0] (glTF's convention); values outside [0,1] repeat the texture.
    std::vector<Vec2> uvs;
    std::vector<uint32_t> indices; // three per triangle, each < positions.size()
    int materialIndex = 0;         // index into Scene::materials

    size_t triangleCount() const { return indices.size() / 3; }
    size_t vertexCount() const { return positions.size(); }
};

// A named camera placement carried by a scene (glTF cameras, generator defaults).
struct Viewpoint {
    std::string name;
    Vec3 eyePos{0.0f};
    Vec3 targetPos{0.0f, 0.0f, -1.0f};
    Vec3 upDir{0.0f, 1.0f, 0.0f};
    float fovYDegrees = 60.0f;
};

struct SceneStats {
    size_t meshes = 0;
    size_t vertices = 0;
    size_t triangles = 0;
    size_t materials = 0;
    size_t textures = 0;
    size_t textureBytes = 0;  // all mip levels, RGBA8
    size_t degenerateTrianglesDropped = 0;
    // Textures a file referred to that could not be loaded (missing or undecodable); the
    // materials using them fall back to their base colour.
    size_t texturesMissing = 0;
    Aabb bounds;
};

class Scene {
public:
    std::vector<Mesh> meshes;
    std::vector<Material> materials;  // at least one after finalize()
    std::vector<Texture> textures;
    std::vector<Viewpoint> viewpoints;
    // The rooms of a generated scene with rooms (office:N, museum:N), one box each, floor to
    // ceiling and wall centre line to wall centre line, in room order; empty for other scenes.
    // The streaming module makes one cell of each (Marvie & Bouatouch section 3).
    std::vector<Aabb> rooms;

    // Checks the scene (finite positions and normals, indices in range, material and texture
    // indices valid, at least one triangle), normalises normals (computing them from faces where
    // a mesh has none), adds a default material when there is none, and computes the triangle
    // offsets, face normals and bounds. Must be called after building or editing the arrays.
    Status finalize();

    size_t triangleCount() const { return mTriangleCount; }
    size_t firstTriangle(size_t meshIndex) const { return mFirstTriangle[meshIndex]; }
    // Mesh holding a global triangle index. Precondition: globalTriangle < triangleCount().
    size_t meshOfTriangle(uint32_t globalTriangle) const;
    // The three corners of a global triangle, in its mesh's index order.
    // Precondition: globalTriangle < triangleCount().
    std::array<Vec3, 3> triangleCorners(uint32_t globalTriangle) const;
    const Aabb& bounds() const { return mBounds; }
    // Unit normal of a triangle's plane, cross(p1 - p0, p2 - p0) normalised ((0, 1, 0) for a
    // degenerate triangle), computed by finalize(): flat shading reads this one vector instead of
    // the triangle's indices and three corners, scattered reads on large meshes.
    // Precondition: globalTriangle < triangleCount().
    const Vec3& faceNormal(size_t globalTriangle) const {
        PLX_DCHECK(globalTriangle < mFaceNormals.size());
        return mFaceNormals[globalTriangle];
    }
    SceneStats stats() const;

    // Counted during import for statistics; finalize() does not change them.
    size_t degenerateTrianglesDropped = 0;
    size_t texturesMissing = 0;
    // What the import left out or repaired, one line each, naming the item and the reason
    // (never quoting file content): e.g. a texture that failed to decode.
    std::vector<std::string> warnings;

private:
    std::vector<size_t> mFirstTriangle;  // per mesh, prefix sums of triangle counts
    std::vector<Vec3> mFaceNormals;      // per global triangle
    size_t mTriangleCount = 0;
    Aabb mBounds;
};

// A viewpoint framing the whole bounding box from the +z side, slightly above.
Viewpoint framingViewpoint(const Aabb& bounds, float fovYDegrees = 60.0f);

// Near and far planes that contain the scene's bounds as seen from eyePos.
void clipPlanesFor(const Aabb& bounds, const Vec3& eyePos, float* nearPlane, float* farPlane);

// A camera at a viewpoint with near and far planes fitted to the scene (clipPlanesFor).
Result<Camera> cameraAt(const Scene& scene, const Viewpoint& viewpoint, int width, int height);

// The scene's first viewpoint, or one framing its bounds when it has none.
Viewpoint defaultViewpoint(const Scene& scene);

// The viewpoint named `which`, else the one at index `which` (decimal); empty: the default
// viewpoint. Errors: kNotFound naming the scene's viewpoints.
Result<Viewpoint> findViewpoint(const Scene& scene, const std::string& which);

}  // namespace plx::scene
