// Pre-checks of text formats whose assimp readers hang or explode on a few hostile bytes: the
// SMD reader loops forever on a file that ends inside its "nodes" block, and the AC3D reader's
// Catmull-Clark subdivision turns "subdiv 12" on one quad into 33 million triangles and 4 GB.

#include "size_check.h"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

namespace plx::scene {

Status checkSmdSections(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    std::string text, word, open;
    uint64_t lineNo = 0, openedAt = 0;
    while (std::getline(in, text)) {
        ++lineNo;
        std::istringstream line(text);
        if (!(line >> word)) continue;
        if (!open.empty()) {
            if (word == "end") open.clear();
        } else if (word == "nodes" || word == "skeleton" || word == "triangles" ||
                   word == "vertexanimation") {
            open = word;
            openedAt = lineNo;
        }
    }
    if (open.empty()) return Status::ok();
    return errorStatus(ErrorCode::kCorruptData,
                       fmt::format("SMD section '{}' (line {}) has no 'end': the file is truncated",
                                   printable(open), openedAt));
}

namespace {

// Triangles one AC3D object becomes: each surface of n corners is n-2 triangles, or, with
// "subdiv s", n quads after the first Catmull-Clark step and 4 times as many after each further
// one, two triangles each. Saturates at UINT64_MAX.
uint64_t ac3dTriangles(uint64_t surfaceCorners, uint64_t surfaces, uint64_t subdiv) {
    if (subdiv == 0) return surfaceCorners >= 2 * surfaces ? surfaceCorners - 2 * surfaces : 0;
    uint64_t quads = surfaceCorners;
    for (uint64_t k = 1; k < subdiv && quads != 0; ++k) {
        if (quads > UINT64_MAX / 4) return UINT64_MAX;
        quads *= 4;
    }
    return quads > UINT64_MAX / 2 ? UINT64_MAX : 2 * quads;
}

}  // namespace

Status checkAc3dSubdivision(const std::string& path, size_t maxTriangles) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return errorStatus(ErrorCode::kIoError, "cannot open the file");
    std::string text, word;
    if (!std::getline(in, text) || text.compare(0, 4, "AC3D") != 0) return Status::ok();
    // Per OBJECT block: its "subdiv" level, its surfaces and their corners ("refs").
    uint64_t total = 0, subdiv = 0, surfaces = 0, corners = 0, maxSubdiv = 0;
    auto closeObject = [&] {
        const uint64_t t = ac3dTriangles(corners, surfaces, subdiv);
        total = t > UINT64_MAX - total ? UINT64_MAX : total + t;
        subdiv = surfaces = corners = 0;
    };
    while (std::getline(in, text)) {
        std::istringstream line(text);
        if (!(line >> word)) continue;
        uint64_t value = 0;
        if (word == "OBJECT") {
            closeObject();
        } else if (word == "subdiv" && line >> value) {
            subdiv = value;
            maxSubdiv = std::max(maxSubdiv, value);
        } else if (word == "refs" && line >> value) {
            corners += value;
            ++surfaces;
        }
        if (total > maxTriangles) break;
    }
    closeObject();
    if (maxSubdiv == 0 || total <= maxTriangles) return Status::ok();
    return errorStatus(
        ErrorCode::kOutOfRange,
        fmt::format("AC3D subdivision (subdiv {}) makes more than the limit of {} triangles",
                    maxSubdiv, maxTriangles));
}

}  // namespace plx::scene
