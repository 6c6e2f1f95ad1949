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
inline constexpr uint16_t kVersion = 1;
inline constexpr size_t kFixedHeaderBytes = 32;
inline constexpr size_t kIndexEntryBytes = 20;
inline constexpr size_t kHeaderCrcBytes = 4;
// Largest accepted side and pixel count (the same bounds as core's image decoders).
inline constexpr int kMaxSide = 32768;
inline constexpr int64_t kMaxPixels = int64_t(1) << 28;

// How a group is stored. kRaw and kPredictZstd share the plane layout; kPredictRans codes the
// same values symbol by symbol in block order; kPredictRansFast in per-row runs whose contexts
// never depend on the same run; kPredictRansSimd as kPredictRansFast with 32 interleaved rANS
// states for a vectorised decoder; kPredictAboveRansSimd as kPredictRansSimd with the block row
// above in two of its models; kPredictCrossRansSimd (the default) as kPredictAboveRansSimd with
// component-major rows and more inter-component models (docs/ptm-format.md).
enum class Coder : uint8_t {
    kRaw = 0,              // planes hold the values themselves, uncompressed (the paper's layout)
    kPredictZstd = 1,      // planes hold prediction residuals; the payload is one zstd frame
    kPredictRans = 2,      // context-modelled residuals and eps, interleaved rANS (no planes)
    kPredictRansFast = 3,  // as 2, symbols in runs with precomputed contexts, 4 rANS states
    kPredictRansSimd = 4,  // as 3 with 32 rANS states, decoded eight at a time (AVX2)
    // as 4; the upper pixels' predictions and the eps contexts also use the block row above
    kPredictAboveRansSimd = 5,
    // as 5, block rows component by component: each component's predictions and contexts also
    // use the components before it in the same block; the encoder picks the shapes' weight
    kPredictCrossRansSimd = 6,
};
inline constexpr Coder kLastCoder = Coder::kPredictCrossRansSimd;
// Coder 6: every group's first byte, the mode (docs/ptm-format.md): 0..kMaxShapeEighths the
// group is modelled (k >= 1: with that shape weight in eighths; k = 0: 0 only),
// kStoredGroupMode it holds coder 0's payload.
inline constexpr int kMaxShapeEighths = 4;
inline constexpr uint8_t kStoredGroupMode = 0xFF;

// Human-readable name of a coder ("raw", "predict+zstd"); "unknown" for other values.
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
