#include <bit>
#include <memory>

#include <fmt/format.h>

#include <plx/ptm/decoder.h>

#include "corrupt.h"
#include "kernels.h"
#include "lowest.h"
#include "raw_layout.h"

static_assert(std::endian::native == std::endian::little, "the bit reader assumes little-endian");

namespace plx::ptm {
namespace {

// The image a group decodes into: the level's size, all bytes allocated.
ByteImage levelImage(LevelSize size, int comps) {
    ByteImage img{size.width, size.height, comps, {}};
    img.bytes.resize(img.rowBytes() * size_t(size.height));
    return img;
}

// The decode tables of groups k >= 1 (one 16 KB table per context table of the group, up to
// 16 families x 16 tables = 4 MB): a buffer per thread, kept between groups and files and grown
// to the largest group seen, because a fresh block per group costs its page faults on every
// group once the allocator has handed it back to the system (docs/ptm-format.md, "Decoder").
// The old block is freed before the larger one is taken, so the peak stays one buffer.
uint32_t* simdTableBuffer(size_t entries) {
    thread_local std::unique_ptr<uint32_t[]> buffer;
    thread_local size_t capacity = 0;
    if (capacity < entries) {
        buffer.reset();
        buffer = std::make_unique_for_overwrite<uint32_t[]>(entries);
        capacity = entries;
    }
    return buffer.get();
}

Status badPixel(int k) {
    return corrupt(fmt::format("level {}: residual error or reconstructed pixel (eq. 3) out of "
                               "range", k));
}

// The checks at the end of a modelled group, as messages.
Status levelStatus(detail::LevelCheck check, int k) {
    switch (check) {
    case detail::LevelCheck::kOk: return Status::ok();
    case detail::LevelCheck::kBadPixel: return badPixel(k);
    case detail::LevelCheck::kRansUnclean:
        return corrupt(fmt::format("level {}: rANS stream does not end cleanly", k));
    case detail::LevelCheck::kExtraBitsMismatch:
        return corrupt(fmt::format("level {}: extra-bit stream length mismatch", k));
    }
    return corrupt(fmt::format("level {}: unknown decode result", k));
}

// Group 0 after its mode byte: the smallest level by two rANS states (lowest.h).
Status decodeLowest(const uint8_t* p, const uint8_t* ransEnd, const uint8_t* end,
                    const std::vector<std::array<uint16_t, detail::kTokenCount>>& freqs,
                    const std::vector<uint16_t>& ctxToTable, ByteImage& img) {
    auto decodeTables = std::make_unique<detail::DecodeTable[]>(freqs.size());
    for (size_t t = 0; t < freqs.size(); ++t) detail::buildDecodeTable(freqs[t], decodeTables[t]);
    detail::LowestDecodeIO io{decodeTables.get(), ctxToTable.data(),
                              detail::RansDecoder(p, ransEnd), detail::BitReader(ransEnd, end)};
    detail::walkLowest(img.bytes.data(), img.width, img.height, img.channels, io);
    if (!io.rans.finishedCleanly()) return levelStatus(detail::LevelCheck::kRansUnclean, 0);
    if (!io.bits.exact(size_t(end - ransEnd)))
        return levelStatus(detail::LevelCheck::kExtraBitsMismatch, 0);
    return Status::ok();
}

// A modelled group (docs/ptm-format.md, "Level groups"): the mode byte (here 0..4), family
// table counts, tables, rANS stream, extra bits. Group 0 by two rANS states, the others by the
// level walker of the active ISA.
Status decodeGroupRans(std::span<const uint8_t> in, const ByteImage* low, ByteImage& img, int k) {
    const bool lowest = k == 0;
    const uint8_t* p = in.data();
    const uint8_t* end = in.data() + in.size();
    if (p == end) return corrupt(fmt::format("level {}: truncated before the mode byte", k));
    const int shapeEighths = *p++;
    const int most = lowest ? 0 : kMaxShapeEighths;
    if (shapeEighths > most)
        return corrupt(fmt::format("level {}: shape weight {} outside 0..{}", k, shapeEighths,
                                   most));
    std::vector<uint16_t> ctxToTable(detail::kMaxRawContexts, 0);
    std::vector<std::array<uint16_t, detail::kTokenCount>> freqs;
    const int families = detail::familyCount(img.channels, lowest);
    if (end - p < families) return corrupt(fmt::format("level {}: truncated context map", k));
    size_t tables = 0;
    std::array<std::array<int, 2>, 16> familyTables{};  // {first table, g} per family
    for (int i = 0; i < families; ++i) {
        const int f = detail::familyId(i, lowest);
        const int raw = detail::familyRawContexts(f & 3);
        const int g = *p++;
        if (g < 1 || g > raw || raw % g != 0)
            return corrupt(fmt::format("level {}: bad table count {} in the context map", k, g));
        for (int q = 0; q < raw; ++q)
            ctxToTable[size_t(f * detail::kFamilyContexts + q)] =
                uint16_t(tables + size_t(q * g / raw));
        familyTables[size_t(f)] = {int(tables), g};
        tables += size_t(g);
    }
    freqs.resize(tables);
    for (auto& f : freqs)
        if (!detail::readTable(p, end, f))
            return corrupt(fmt::format("level {}: malformed frequency table", k));
    if (end - p < 4) return corrupt(fmt::format("level {}: truncated before the rANS stream", k));
    const uint32_t ransBytes =
        uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
    p += 4;
    const int storedStates = detail::simdStoredStates(img.channels, img.width);
    const uint32_t minBytes = lowest ? 8 : 4 * uint32_t(storedStates);
    if (ransBytes < minBytes || ransBytes > size_t(end - p) || ransBytes % 2 != 0)
        return corrupt(fmt::format("level {}: rANS stream length {} out of range", k, ransBytes));
    if (lowest) return decodeLowest(p, p + ransBytes, end, freqs, ctxToTable, img);
    detail::LevelStreams streams;
    streams.entries = simdTableBuffer(tables * detail::kRansTotal);  // 16 KB per table
    streams.familyTables = &familyTables;
    streams.freqs = freqs;
    streams.shapeEighths = shapeEighths;
    streams.storedStates = storedStates;
    streams.rans = p;
    streams.ransEnd = p + ransBytes;
    streams.bitsEnd = end;
    using namespace detail;
    return levelStatus(PLX_ISA_PICK(decodeLevel)(streams, *low, img), k);
}

// A raw group (coder kRaw, or a stored group): the planes of raw_layout.h.
Status decodeGroupRaw(std::span<const uint8_t> in, const ByteImage* low, ByteImage& img, int k) {
    const detail::GroupLayout layout =
        detail::groupLayout({img.width, img.height}, img.channels, k == 0);
    if (in.size() != layout.payloadBytes())
        return corrupt(fmt::format("level {} raw group has {} bytes, needs {}", k, in.size(),
                                   layout.payloadBytes()));
    // The walker reads the planes through a mutable pointer (it also encodes).
    uint8_t* payload = const_cast<uint8_t*>(in.data());
    if (k == 0) {
        detail::walkRawLowest<false>(img.bytes.data(), img.width, img.height, img.channels,
                                     payload);
        return Status::ok();
    }
    if (!detail::walkRawLevelAny<false>(img.channels, *low, img.bytes.data(), img.width,
                                        img.height, payload))
        return badPixel(k);
    return Status::ok();
}

}  // namespace

Result<ProgressiveDecoder> ProgressiveDecoder::create(std::span<const uint8_t> headerPrefix) {
    auto header = parseHeader(headerPrefix);
    if (!header) return header.status();
    return ProgressiveDecoder(std::move(header).value());
}

const ByteImage& ProgressiveDecoder::level(int k) const {
    PLX_CHECK(k >= 0 && k < levelsDecoded());
    return mLevels[size_t(k)];
}

Status ProgressiveDecoder::addGroup(std::span<const uint8_t> groupBytes) {
    PLX_CHECK(!complete());
    const int k = levelsDecoded();
    const GroupEntry& entry = mHeader.groups[size_t(k)];
    if (groupBytes.size() != entry.size)
        return corrupt(fmt::format("level {} group has {} bytes, the index says {}", k,
                                   groupBytes.size(), entry.size));
    if (crc32(groupBytes) != entry.crc32) return corrupt(fmt::format("level {} checksum mismatch", k));
    ByteImage img = levelImage(mHeader.levelSize(k), mHeader.components);
    const ByteImage* low = k > 0 ? &mLevels.back() : nullptr;
    const bool stored = mHeader.coder == Coder::kRans && !groupBytes.empty() &&
                        groupBytes[0] == kStoredGroupMode;
    if (mHeader.coder == Coder::kRans && !stored) {
        PLX_RETURN_IF_ERROR(decodeGroupRans(groupBytes, low, img, k));
    } else {
        if (stored) groupBytes = groupBytes.subspan(1);  // coder kRaw's payload follows
        PLX_RETURN_IF_ERROR(decodeGroupRaw(groupBytes, low, img, k));
    }
    mLevels.push_back(std::move(img));
    return Status::ok();
}

Result<ByteImage> decodeLevel(std::span<const uint8_t> filePrefix, int k) {
    auto decoder = ProgressiveDecoder::create(filePrefix);
    if (!decoder) return decoder.status();
    const Header& h = decoder->header();
    if (k < 0 || k >= h.levelCount)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("PTM: level {} outside 0..{}", k, h.levelCount - 1));
    for (int i = 0; i <= k; ++i) {
        const ByteRange range = levelByteRange(h, i);
        if (range.offset + range.size > filePrefix.size())
            return corrupt(fmt::format("file truncated in level {} (needs {} bytes, has {})", i,
                                       range.offset + range.size, filePrefix.size()));
        PLX_RETURN_IF_ERROR(decoder->addGroup(filePrefix.subspan(range.offset, range.size)));
    }
    std::vector<ByteImage> levels = decoder->takeLevels();
    return std::move(levels.back());
}

Result<ByteImage> decodeImage(std::span<const uint8_t> file) {
    auto header = parseHeader(file);
    if (!header) return header.status();
    if (file.size() != header->fileBytes())
        return corrupt(fmt::format("file has {} bytes, the index says {}", file.size(),
                                   header->fileBytes()));
    return decodeLevel(file, header->levelCount - 1);
}

Result<std::vector<ByteImage>> decodeAllLevels(std::span<const uint8_t> file) {
    auto decoder = ProgressiveDecoder::create(file);
    if (!decoder) return decoder.status();
    const Header& h = decoder->header();
    if (file.size() != h.fileBytes())
        return corrupt(fmt::format("file has {} bytes, the index says {}", file.size(),
                                   h.fileBytes()));
    for (int i = 0; i < h.levelCount; ++i) {
        const ByteRange range = levelByteRange(h, i);
        PLX_RETURN_IF_ERROR(decoder->addGroup(file.subspan(range.offset, range.size)));
    }
    return decoder->takeLevels();
}

}  // namespace plx::ptm
