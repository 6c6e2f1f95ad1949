#include "vertex_join.h"

#include <cstring>

namespace plx::scene {

std::vector<uint32_t> firstIdenticalVertex(const aiMesh& m) {
    // The bits of the attributes the import keeps: position, normal, UV (zero where absent).
    return firstIdentical(m.mNumVertices, [&](size_t v) {
        float f[8] = {m.mVertices[v].x, m.mVertices[v].y, m.mVertices[v].z, 0, 0, 0, 0, 0};
        if (m.mNormals) {
            f[3] = m.mNormals[v].x;
            f[4] = m.mNormals[v].y;
            f[5] = m.mNormals[v].z;
        }
        if (m.HasTextureCoords(0)) {
            f[6] = m.mTextureCoords[0][v].x;
            f[7] = m.mTextureCoords[0][v].y;
        }
        std::array<uint32_t, 8> bits;
        std::memcpy(bits.data(), f, sizeof f);
        return bits;
    });
}

}  // namespace plx::scene
