#pragma once
// Test helper: hostile PTM files that pass every checksum.

#include <cstdint>
#include <span>
#include <vector>

#include <plx/ptm/format.h>

namespace plx::ptm {

// Flips bits `flip` of byte `at` (mod the group's size) of group k and recomputes the group's
// index CRC and the header CRC, as a hostile file would.
inline std::vector<uint8_t> corruptGroup(std::vector<uint8_t> file, int k, size_t at,
                                         uint8_t flip) {
    auto h = parseHeader(file);
    const ByteRange r = levelByteRange(*h, k);
    file[r.offset + at % r.size] ^= flip;
    const uint32_t c = crc32(std::span(file).subspan(r.offset, r.size));
    const size_t entry = kFixedHeaderBytes + size_t(k) * kIndexEntryBytes + 16;
    for (int i = 0; i < 4; ++i) file[entry + size_t(i)] = uint8_t(c >> (8 * i));
    const size_t headerBytes = h->headerBytes();
    const uint32_t hc = crc32(std::span(file).first(headerBytes - 4));
    for (int i = 0; i < 4; ++i) file[headerBytes - 4 + size_t(i)] = uint8_t(hc >> (8 * i));
    return file;
}

}  // namespace plx::ptm
