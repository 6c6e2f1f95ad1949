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

}  // namespace plx::scene
