#pragma once
// Loading scenes: from files through assimp (glTF/GLB, OBJ, PLY, FBX, IFC, anything assimp
// reads; embedded and external textures), or from a generator spec such as "office:8".

#include <string>

#include <plx/scene/scene.h>

namespace plx::scene {

struct ImportOptions {
    bool loadTextures = true;
    // Files declaring more than this many triangles or vertices are refused before allocation.
    size_t maxTriangles = size_t(1) << 28;
};

// Imports a model file: triangles of every mesh instance baked into world space, normals kept
// (generated where absent, smooth up to 80 degrees), the first UV set, base colour factors and
// textures (embedded or next to the model; one that cannot be loaded leaves the material
// untextured and is counted in Scene::texturesMissing), cameras as viewpoints. Errors name the
// file and the problem (missing, empty, corrupt or truncated, no triangles, non-finite
// vertices, absurd declared counts: PLY headers and OBJ contents are checked against the file
// size and options.maxTriangles before assimp allocates anything). Degenerate triangles
// (repeated indices or zero area) are dropped and counted in Scene::degenerateTrianglesDropped.
Result<Scene> importFile(const std::string& path, const ImportOptions& options = {});

// True when spec names a generator ("office:N", "museum:N", "showcase") rather than a file.
bool isGeneratorSpec(const std::string& spec);

// A scene from a file path or a generator spec.
Result<Scene> loadScene(const std::string& spec, const ImportOptions& options = {});

}  // namespace plx::scene
