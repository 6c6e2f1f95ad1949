#pragma once
// The PTM file format (docs/ptm-format.md): a fixed header, a level index listing each level
// group's byte range and CRC-32 smallest level first, a CRC-32 over header and index, then the
// level groups. Everything little-endian. This header is shared by the decoder and the encoder.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <plx/core/status.h>
#include <plx/ptm/mip.h>

namespace plx::ptm {

// File signature: PNG-style, catches text-mode and truncation mangling.
inline constexpr uint8_t kMagic[8] = {0x89, 'P', 'T', 'M', '\r', '\n', 0x1A, '\n'};
inline constexpr uint16_t kVersion = 2;
inline constexpr size_t kFixedHeaderBytes = 32;
inline constexpr size_t kIndexEntryBytes = 20;
inline constexpr size_t kHeaderCrcBytes = 4;
// Largest accepted side and pixel count (the same bounds as core's image decoders).
inline constexpr int kMaxSide = 32768;
inline constexpr int64_t kMaxPixels = int64_t(1) << 28;

// How a file's groups are stored (docs/ptm-format.md). Version 2 keeps two coders: the
// context-modelled rANS coder every encoder writes by default, and raw values for debugging.
enum class Coder : uint8_t {
    kRaw = 0,   // groups hold the values themselves, uncompressed (the paper's plane layout)
    kRans = 1,  // context-modelled residuals and eps in 32 interleaved rANS states, per group a
                // mode byte (below) that may also store the group raw
};
inline constexpr Coder kLastCoder = Coder::kRans;
// Coder kRans: every group's first byte, the mode (docs/ptm-format.md): 0..kMaxShapeEighths the
// group is modelled (k >= 1: with that shape weight in eighths; k = 0: 0 only),
// kStoredGroupMode it holds coder kRaw's payload.
inline constexpr int kMaxShapeEighths = 4;
inline constexpr uint8_t kStoredGroupMode = 0xFF;

// Name of a coder as the CLI spells it ("raw", "rans"); "unknown" for other values.
const char* coderName(Coder coder);

// One entry of the level index: where group k lies in the file and its CRC-32.
struct GroupEntry {
    uint64_t offset = 0;  // from the start of the file; group 0 starts right after the header
    uint64_t size = 0;    // bytes; groups are contiguous: offset[k+1] = offset[k] + size[k]
    uint32_t crc32 = 0;   // CRC-32 (IEEE, zlib's) of the group's bytes
};

// Parsed and validated header plus index.
struct Header {
    int width = 0;        // base (largest) level, 1..kMaxSide
    int height = 0;       // 1..kMaxSide, width * height <= kMaxPixels
    int components = 0;   // 1..4 interleaved 8-bit channels
    int levelCount = 0;   // 1..fullChainLength(width, height)
    LevelSize lowest;     // size of level 0, the smallest stored level (redundant, checked)
    Coder coder = Coder::kRaw;
    std::vector<GroupEntry> groups;  // levelCount entries, index 0 = smallest level

    // Bytes of header + index + header CRC; group 0 starts here.
    size_t headerBytes() const;
    // Size of stored level k (0 = smallest). Precondition: 0 <= k < levelCount.
    LevelSize levelSize(int k) const;
    // File size implied by the index (end of the last group).
    uint64_t fileBytes() const;
};

// Bytes of header + index + header CRC for a file with levelCount levels.
size_t headerBytesFor(int levelCount);

// Parses and validates header and index from the first bytes of a file. Errors name the field
// (bad magic, unsupported version, sizes out of range, offsets not contiguous, header CRC).
Result<Header> parseHeader(std::span<const uint8_t> prefix);

// Serialises header and index (with its CRC). Precondition: header fields within their ranges.
std::vector<uint8_t> writeHeader(const Header& header);

// Byte range [offset, offset + size) of level group k, for HTTP Range requests.
// Precondition: 0 <= k < header.levelCount.
struct ByteRange {
    uint64_t offset = 0;
    uint64_t size = 0;
};
ByteRange levelByteRange(const Header& header, int k);

// CRC-32 (IEEE 802.3 polynomial, reflected, as zlib's crc32); `crc` continues a previous value.
// Uses carry-less multiplication (PCLMULQDQ) where the build has it.
uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc = 0);
// The same CRC-32 by table look-ups only (slicing by 8): the reference that crc32 is tested
// against.
uint32_t crc32Portable(std::span<const uint8_t> bytes, uint32_t crc = 0);

}  // namespace plx::ptm
