#pragma once
// Checks run on a model file before assimp reads it: element counts a header declares are
// compared with the file's size and with the import limit, so that a hostile or corrupt header
// ("element vertex 4000000000") is refused before anything is allocated for it.

#include <cstdint>
#include <string>

#include <plx/core/status.h>

namespace plx::scene {

// PLY: the header must end with an end_header line, and each "element NAME COUNT" of the header needs at least COUNT times the smallest encoding
// of its properties (2 bytes per ASCII property, the scalar sizes in binary files) after
// "end_header", and COUNT must not exceed maxElements. Messages do not name the file.
Status checkPlyCounts(const std::string& path, uintmax_t fileSize, size_t maxElements);

// OBJ: the vertices ("v") and the triangles the faces ("f") triangulate into must not exceed
// maxElements. Streams the file once.
Status checkObjCounts(const std::string& path, size_t maxElements);

// OFF: the vertex and face counts of the header must not exceed maxElements nor need more bytes
// than the file holds (6 a vertex, 4 a face), and every face index must name a declared vertex
// (assimp would clamp it). Streams the file once.
Status checkOffFile(const std::string& path, uintmax_t fileSize, size_t maxElements);

// DirectX .x (text files): every face index of each Mesh must name one of its vertices
// (assimp 5.2 silently drops a face that does not). Reads the file whole.
Status checkXFaces(const std::string& path, uintmax_t fileSize);

// glTF (.gltf or .glb): the node graph expanded as assimp expands it (a node listed twice as a
// child is copied twice, recursively) must stay within maxNodes node copies and maxTriangles
// triangles (each mesh counted at each copy), and must have no cycle. Parses the JSON only.
Status checkGltfExpansion(const std::string& path, uintmax_t fileSize, size_t maxNodes,
                          size_t maxTriangles);

// SMD: every section ("nodes", "skeleton", "triangles", "vertexanimation") must be closed by
// an "end" line; assimp's reader loops forever on a file that ends inside "nodes".
Status checkSmdSections(const std::string& path);

// AC3D: the triangles that Catmull-Clark subdivision ("subdiv N" of an object) makes of the
// file's surfaces must not exceed maxTriangles. Streams the file once.
Status checkAc3dSubdivision(const std::string& path, size_t maxTriangles);

}  // namespace plx::scene
