#pragma once
// Loading scenes: from files through assimp (glTF/GLB, OBJ, PLY, FBX, IFC, anything assimp
// reads; embedded and external textures), or from a generator spec such as "office:8".

#include <string>

#include <plx/scene/scene.h>

namespace plx::scene {

// Limits of an isolated import: the file is parsed in a child process (fork) whose address
// space, CPU time and parser stack are capped, so that a crash, a hang or a runaway allocation in
// a third-party parser becomes an error naming the file instead of taking the caller down.
struct IsolationLimits {
    // Off by default in the library (the caller's choice); the parallax CLI turns it on.
    bool enabled = false;
    // Address space of the child (RLIMIT_AS), also the most bytes its result may take.
    size_t maxMemoryBytes = size_t(4) << 30;
    // CPU time of the child (RLIMIT_CPU) and, as wall-clock time, the parent's deadline.
    double maxSeconds = 60.0;
    // Stack of the thread that runs the parser in the child.
    size_t maxStackBytes = size_t(64) << 20;
};

struct ImportOptions {
    bool loadTextures = true;
    // Files declaring more than this many triangles or vertices are refused before allocation;
    // the limit also holds after instancing (each placement of a mesh counts).
    size_t maxTriangles = size_t(1) << 28;
    // Mesh placements after node instancing (a node listed twice as a child is copied twice):
    // a few bytes of glTF can otherwise ask for 2^40 nodes.
    size_t maxNodeCopies = size_t(1) << 20;
    // Corners of one polygon: assimp's triangulation is quadratic in them (100,000 corners take
    // about a minute; 4096 about 0.1 s).
    size_t maxPolygonCorners = 4096;
    // Triangles that subdivision in the file makes (AC3D "subdiv"): assimp's Catmull-Clark
    // subdivider grows faster than linearly (2^17 triangles take 0.3 s, 2^19 1.7 s, 2^25 24 s and
    // 4 GB), so a few bytes can ask for minutes.
    size_t maxSubdividedTriangles = size_t(1) << 17;
    // Pixels of one decoded texture (kDefaultMaxPixels: 64 Mpix).
    int64_t maxTexturePixels = int64_t(1) << 26;
    // Files the model refers to (buffers, images, material libraries) are read only from the
    // model's folder and below, after resolving "..", absolute paths, file:// and symlinks;
    // true follows references anywhere.
    bool allowExternalRefs = false;
    // Parse in a child process with these limits (importFileIsolated) when enabled.
    IsolationLimits isolation;
};

// Imports a model file: triangles of every mesh instance baked into world space, normals kept
// (generated where absent, smooth up to 80 degrees), the first UV set, base colour factors and
// textures (embedded or in the model's folder; one that cannot be loaded leaves the material
// untextured, is counted in Scene::texturesMissing and named in Scene::warnings), cameras as
// viewpoints. References outside the model's folder are errors unless
// options.allowExternalRefs. Errors name the
// file and the problem (missing, empty, corrupt or truncated, no triangles, non-finite
// vertices, absurd declared counts: PLY headers and OBJ contents are checked against the file
// size and options.maxTriangles before assimp allocates anything). Degenerate triangles
// (repeated indices or zero area) are dropped and counted in Scene::degenerateTrianglesDropped.
// With options.isolation.enabled the work is done by importFileIsolated.
Result<Scene> importFile(const std::string& path, const ImportOptions& options = {});

// importFile run in a forked child under options.isolation's limits; the scene comes back over a
// pipe in a checked binary form. A crash, a limit reached or the deadline passed is one error
// naming the file and what happened ("crashed (segmentation fault)", "took longer than 60 s",
// "needed more than 4096 MB of memory"). The child runs only the import (no thread pools, no
// callbacks into the caller); a lock held by another of the caller's threads at fork time can
// only make the child miss its deadline, which is reported like any timeout. POSIX only.
Result<Scene> importFileIsolated(const std::string& path, const ImportOptions& options);

// True when spec names a generator ("office:N", "museum:N", "showcase") rather than a file.
bool isGeneratorSpec(const std::string& spec);

// A scene from a file path or a generator spec.
Result<Scene> loadScene(const std::string& spec, const ImportOptions& options = {});

}  // namespace plx::scene
