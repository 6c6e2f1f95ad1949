#pragma once
// Joining identical vertices in linear time (used by import.cpp in place of assimp's
// aiProcess_JoinIdenticalVertices, whose spatial sort took 0.6 s of a 400,000-triangle OBJ's
// 1 s import: the OBJ reader gives every face corner a vertex of its own), and grouping equal
// positions for normal generation (normals.cpp).

#include <array>
#include <bit>
#include <cstdint>
#include <vector>

#include <assimp/mesh.h>

namespace plx::scene {

// For items 0..n-1 whose attribute bits bitsOf(i) gives (a std::array<uint32_t, N>), the index
// of the first item with the same bits. Expected linear time: open addressing with linear
// probing in a table at most half full, each slot holding the first item seen with some bits.
template <class BitsOf>
std::vector<uint32_t> firstIdentical(size_t n, const BitsOf& bitsOf) {
    constexpr uint32_t kEmpty = UINT32_MAX;
    const size_t slots = std::bit_ceil(2 * n + 2);
    std::vector<uint32_t> table(slots, kEmpty), first(n);
    for (size_t i = 0; i < n; ++i) {
        const auto bits = bitsOf(i);
        uint64_t h = 0x9E3779B97F4A7C15ull;
        for (uint32_t w : bits) h = (h ^ w) * 0xFF51AFD7ED558CCDull;
        size_t s = size_t(h ^ (h >> 32)) & (slots - 1);
        while (table[s] != kEmpty && bitsOf(table[s]) != bits) s = (s + 1) & (slots - 1);
        if (table[s] == kEmpty) table[s] = uint32_t(i);
        first[i] = table[s];
    }
    return first;
}

// For each vertex of the mesh, the first vertex whose position, normal (when the mesh has
// normals) and first UV set (when it has one) have the same bits: exact duplicates only, so
// joining them changes nothing that is drawn.
std::vector<uint32_t> firstIdenticalVertex(const aiMesh& mesh);

}  // namespace plx::scene
