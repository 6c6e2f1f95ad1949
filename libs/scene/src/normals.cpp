#include "normals.h"

#include <cmath>
#include <cstring>

#include "vertex_join.h"

namespace plx::scene {
namespace {

// The faces around each position as compressed rows: faces of group g are
// faces[start[g] .. start[g + 1]), in triangle order. groupOf gives each corner's group.
struct FacesAround {
    std::vector<uint32_t> groupOf, start, faces;
};

FacesAround groupCorners(const std::vector<Vec3>& pos, const std::vector<Corners>& tris) {
    FacesAround g;
    g.groupOf.resize(3 * tris.size());
    // Positions by their exact bits (files often repeat a position with other UVs), hashed once
    // per position rather than once per corner.
    const std::vector<uint32_t> samePos = firstIdentical(pos.size(), [&](size_t v) {
        std::array<uint32_t, 3> bits;
        std::memcpy(bits.data(), &pos[v], sizeof bits);
        return bits;
    });
    std::vector<uint32_t> groupOfPos(pos.size(), UINT32_MAX), counts;
    for (size_t c = 0; c < g.groupOf.size(); ++c) {
        uint32_t& group = groupOfPos[samePos[tris[c / 3][c % 3]]];
        if (group == UINT32_MAX) {
            group = uint32_t(counts.size());
            counts.push_back(0);
        }
        ++counts[group];
        g.groupOf[c] = group;
    }
    g.start.assign(counts.size() + 1, 0);
    for (size_t i = 0; i < counts.size(); ++i) g.start[i + 1] = g.start[i] + counts[i];
    g.faces.resize(3 * tris.size());
    std::vector<uint32_t> fill(g.start.begin(), g.start.end() - 1);
    for (size_t c = 0; c < g.groupOf.size(); ++c) g.faces[fill[g.groupOf[c]]++] = uint32_t(c / 3);
    return g;
}

}  // namespace

std::vector<Vec3> smoothCornerNormals(const std::vector<Vec3>& pos,
                                      const std::vector<Corners>& tris) {
    const float cosLimit = std::cos(radians(80.0f));
    std::vector<Vec3> faceN(tris.size()), unitN(tris.size());
    for (size_t t = 0; t < tris.size(); ++t) {
        const Corners& c = tris[t];
        faceN[t] = glm::cross(pos[c[1]] - pos[c[0]], pos[c[2]] - pos[c[0]]);
        float len = glm::length(faceN[t]);
        unitN[t] = len > 0.0f ? faceN[t] / len : Vec3(0.0f);
    }
    FacesAround around = groupCorners(pos, tris);
    // Busy positions: the plain sum, computed once per position rather than once per corner
    // (a fan of n faces around one vertex would otherwise cost n^2).
    const size_t groups = around.start.size() - 1;
    std::vector<Vec3> busySum(groups, Vec3(0.0f));
    for (size_t g = 0; g < groups; ++g)
        if (around.start[g + 1] - around.start[g] > kMaxPairwiseFaces)
            for (uint32_t i = around.start[g]; i < around.start[g + 1]; ++i)
                busySum[g] += faceN[around.faces[i]];
    std::vector<Vec3> out(3 * tris.size());
    for (size_t c = 0; c < out.size(); ++c) {
        const uint32_t g = around.groupOf[c], first = around.start[g], end = around.start[g + 1];
        if (end - first > kMaxPairwiseFaces) {
            out[c] = busySum[g];
            continue;
        }
        const size_t t = c / 3;
        Vec3 n(0.0f);
        for (uint32_t i = first; i < end; ++i) {
            const uint32_t u = around.faces[i];
            if (glm::dot(unitN[u], unitN[t]) >= cosLimit) n += faceN[u];
        }
        out[c] = n;
    }
    return out;
}

}  // namespace plx::scene
