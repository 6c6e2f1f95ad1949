#include <cstring>

#include <fmt/format.h>

#include <plx/ptm/format.h>

#include "corrupt.h"

namespace plx::ptm {
namespace {

uint32_t readU32(const uint8_t* p) {
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
uint64_t readU64(const uint8_t* p) { return uint64_t(readU32(p)) | uint64_t(readU32(p + 4)) << 32; }
void putU32(std::vector<uint8_t>& out, uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
void putU64(std::vector<uint8_t>& out, uint64_t v) {
    putU32(out, uint32_t(v));
    putU32(out, uint32_t(v >> 32));
}

}  // namespace

const char* coderName(Coder coder) {
    switch (coder) {
    case Coder::kRaw: return "raw";
    case Coder::kRans: return "rans";
    }
    return "unknown";
}

size_t headerBytesFor(int levelCount) {
    return kFixedHeaderBytes + size_t(levelCount) * kIndexEntryBytes + kHeaderCrcBytes;
}

size_t Header::headerBytes() const { return headerBytesFor(levelCount); }

LevelSize Header::levelSize(int k) const {
    PLX_CHECK(k >= 0 && k < levelCount);
    LevelSize s{width, height};
    for (int i = levelCount - 1; i > k; --i) s = lowerLevelSize(s);
    return s;
}

uint64_t Header::fileBytes() const {
    return groups.empty() ? headerBytes() : groups.back().offset + groups.back().size;
}

Result<Header> parseHeader(std::span<const uint8_t> prefix) {
    if (prefix.size() < kFixedHeaderBytes)
        return corrupt(fmt::format("file truncated in the header ({} of {} bytes)", prefix.size(),
                                   kFixedHeaderBytes));
    const uint8_t* p = prefix.data();
    if (std::memcmp(p, kMagic, sizeof(kMagic)) != 0) return corrupt("bad magic (not a PTM file)");
    const unsigned version = unsigned(p[8]) | unsigned(p[9]) << 8;
    if (version < kVersion)  // version 1's seven coders are gone (docs/ptm-format.md)
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("PTM format version {} is no longer supported: re-encode "
                                       "with this version ({})",
                                       version, kVersion));
    if (version != kVersion)
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("PTM: unsupported version {} (this build reads {})",
                                       version, kVersion));
    Header h;
    h.components = p[10];
    const uint8_t coder = p[11];
    const uint32_t width = readU32(p + 12), height = readU32(p + 16);
    h.levelCount = p[20];
    const uint32_t lowW = readU32(p + 24), lowH = readU32(p + 28);
    if (h.components < 1 || h.components > 4)
        return corrupt(fmt::format("component count {} outside 1..4", h.components));
    if (coder > uint8_t(kLastCoder)) return corrupt(fmt::format("unknown coder {}", coder));
    h.coder = Coder(coder);
    if (width < 1 || height < 1 || width > uint32_t(kMaxSide) || height > uint32_t(kMaxSide) ||
        int64_t(width) * height > kMaxPixels)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("PTM: size {}x{} outside 1x1..{}x{} or over {} pixels",
                                       width, height, kMaxSide, kMaxSide, kMaxPixels));
    h.width = int(width);
    h.height = int(height);
    if (p[21] != 0 || p[22] != 0 || p[23] != 0) return corrupt("reserved header bytes not zero");
    const int chain = fullChainLength(h.width, h.height);
    if (h.levelCount < 1 || h.levelCount > chain)
        return corrupt(fmt::format("level count {} outside 1..{} for {}x{}", h.levelCount, chain,
                                   h.width, h.height));
    h.lowest = h.levelSize(0);
    if (lowW != uint32_t(h.lowest.width) || lowH != uint32_t(h.lowest.height))
        return corrupt(fmt::format("lowest level {}x{} does not match {} levels of {}x{}", lowW,
                                   lowH, h.levelCount, h.width, h.height));
    const size_t headerBytes = h.headerBytes();
    if (prefix.size() < headerBytes)
        return corrupt(fmt::format("file truncated in the level index ({} of {} bytes)",
                                   prefix.size(), headerBytes));
    const uint32_t storedCrc = readU32(p + headerBytes - kHeaderCrcBytes);
    if (crc32(prefix.first(headerBytes - kHeaderCrcBytes)) != storedCrc)
        return corrupt("header checksum mismatch");
    uint64_t expectedOffset = headerBytes;
    for (int k = 0; k < h.levelCount; ++k) {
        const uint8_t* e = p + kFixedHeaderBytes + size_t(k) * kIndexEntryBytes;
        GroupEntry g{readU64(e), readU64(e + 8), readU32(e + 16)};
        if (g.offset != expectedOffset)
            return corrupt(fmt::format("level {} offset {} is not {} (groups are contiguous)", k,
                                       g.offset, expectedOffset));
        // A group never exceeds 2 GiB (1 GiB of pixels at most, plus its tables).
        if (g.size == 0 || g.size > (uint64_t(1) << 31))
            return corrupt(fmt::format("level {} size {} out of range", k, g.size));
        expectedOffset += g.size;
        h.groups.push_back(g);
    }
    return h;
}

std::vector<uint8_t> writeHeader(const Header& h) {
    PLX_CHECK(h.components >= 1 && h.components <= 4 && h.levelCount >= 1);
    PLX_CHECK(h.groups.size() == size_t(h.levelCount));
    std::vector<uint8_t> out(kMagic, kMagic + sizeof(kMagic));
    out.push_back(uint8_t(kVersion & 0xFF));
    out.push_back(uint8_t(kVersion >> 8));
    out.push_back(uint8_t(h.components));
    out.push_back(uint8_t(h.coder));
    putU32(out, uint32_t(h.width));
    putU32(out, uint32_t(h.height));
    out.push_back(uint8_t(h.levelCount));
    out.insert(out.end(), 3, 0);
    putU32(out, uint32_t(h.lowest.width));
    putU32(out, uint32_t(h.lowest.height));
    for (const GroupEntry& g : h.groups) {
        putU64(out, g.offset);
        putU64(out, g.size);
        putU32(out, g.crc32);
    }
    putU32(out, crc32(out));
    return out;
}

ByteRange levelByteRange(const Header& header, int k) {
    PLX_CHECK(k >= 0 && k < header.levelCount);
    return {header.groups[size_t(k)].offset, header.groups[size_t(k)].size};
}

}  // namespace plx::ptm
