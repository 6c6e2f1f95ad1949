#pragma once
// Private: the per-ISA entry points of the PTM hot loops (decode_kernels.inl,
// encode_kernels.inl, crc32_kernels.inl), compiled once per ISA by plx_add_isa_kernels and
// picked once per group with PLX_ISA_PICK (<plx/core/cpu.h>). Their arguments are plain views
// and caller-owned buffers, so no container instantiation crosses from one ISA to another.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include <plx/core/cpu.h>
#include <plx/core/image.h>

#include "rans.h"

namespace plx::ptm::detail {

// What the decoder needs of a group k >= 1 beyond its level: a buffer for its decode tables
// (kRansTotal entries per table, which decodeLevel fills), per family {first table, g} of the
// context map, the group's frequency tables, its shape weight, and its two streams.
struct LevelStreams {
    uint32_t* entries = nullptr;
    const std::array<std::array<int, 2>, 16>* familyTables = nullptr;
    std::span<const std::array<uint16_t, kTokenCount>> freqs;
    int shapeEighths = 0;
    int storedStates = 0;  // simdStoredStates of the level
    const uint8_t* rans = nullptr;
    const uint8_t* ransEnd = nullptr;  // where the extra bits begin
    const uint8_t* bitsEnd = nullptr;
};

// How a group's decode ended.
enum class LevelCheck : uint8_t {
    kOk,
    kBadPixel,          // an eps >= n or a pixel of eq. (3) outside 0..255
    kRansUnclean,       // the rANS stream does not end where and as it must
    kExtraBitsMismatch  // the extra bits do not fill their stream exactly
};

// What the encoder's walk of a group k >= 1 produced into its buffers.
struct LevelTokens {
    size_t symbols = 0;
    size_t bitCount = 0;  // extra bits
    size_t bitBytes = 0;
};

// Upper bounds of a level's symbols and extra-bit bytes, for the encoder's buffers: four
// symbols per block and component, six extra bits each at most.
inline size_t maxLevelSymbols(const ByteImage& lowerLevel) {
    return 4 * size_t(lowerLevel.channels) * size_t(lowerLevel.width) * size_t(lowerLevel.height);
}
inline size_t maxExtraBytes(size_t symbols) { return (6 * symbols + 7) / 8; }

// Decodes group k >= 1 into `level` (allocated, the level's size) from the complete `lower`
// level.
PLX_ISA_DECLARE(LevelCheck decodeLevel(const LevelStreams& streams, const ByteImage& lower,
                                       ByteImage& level))
// Walks group k >= 1 of `level` for the encoder with shape weight shapeEighths: its symbols
// into `symbols` (maxLevelSymbols(lower) entries), its extra bits into `bits`
// (maxExtraBytes of that).
PLX_ISA_DECLARE(LevelTokens encodeLevel(const ByteImage& lower, const ByteImage& level,
                                        int shapeEighths, LaneSymbol* symbols, uint8_t* bits))
// Continues the inverted CRC-32 register c over n bytes; the scalar entry by table look-ups.
PLX_ISA_DECLARE(uint32_t crc32Update(const uint8_t* p, size_t n, uint32_t c))

}  // namespace plx::ptm::detail
