#include <bit>
#include <memory>

#include <fmt/format.h>
#include <zstd.h>

#include <plx/ptm/decoder.h>

#include "codec.h"
#include "ctx_codec.h"
#include "fast_codec.h"
#include "simd_codec.h"

static_assert(std::endian::native == std::endian::little, "the bit reader assumes little-endian");

namespace plx::ptm {
namespace {

Status corrupt(std::string message) {
    return errorStatus(ErrorCode::kCorruptData, "PTM: " + std::move(message));
}

// The image a group decodes into: the level's size, all bytes allocated.
ByteImage levelImage(LevelSize size, int comps) {
    ByteImage img{size.width, size.height, comps, {}};
    img.bytes.resize(img.rowBytes() * size_t(size.height));
    return img;
}

// Decompresses one zstd frame that must fill `out` exactly and use every input byte.
Status unzstd(std::span<const uint8_t> in, std::span<uint8_t> out, int k) {
    const unsigned long long declared = ZSTD_getFrameContentSize(in.data(), in.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN)
        return corrupt(fmt::format("level {}: payload is not a zstd frame with a size", k));
    if (declared != out.size())
        return corrupt(fmt::format("level {}: payload declares {} bytes, the level needs {}", k,
                                   declared, out.size()));
    const size_t frame = ZSTD_findFrameCompressedSize(in.data(), in.size());
    if (ZSTD_isError(frame) || frame != in.size())
        return corrupt(fmt::format("level {}: zstd frame does not span the group", k));
    const size_t got = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(got) || got != out.size())
        return corrupt(fmt::format("level {}: zstd: {}", k,
                                   ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short payload"));
    return Status::ok();
}

// The decode tables of coders 4 to 6 (one 16 KB table per context table of the group, up to
// 16 families x 16 tables = 4 MB): a buffer per thread, kept between groups and files and grown
// to the largest group seen. A fresh 2.5 MB block per group (an RGB level's 156 tables) costs
// its page faults on every group once the allocator has handed it back to the system: decoding
// the four speed-table textures from .ptm files in a fresh process ran at 135.8 / 133.9 MB/s
// (two cores) with it and at 293.1 / 273.7 MB/s with this buffer (docs/ptm-results.md, "Coder 6
// decode on AVX-512"). The old block is freed before the larger one is taken, so the peak stays
// one buffer.
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

// Coders 3 to 6, group k >= 1: runtime component count to the walker's template argument.
template <class IO>
bool decodeLevelFast(int comps, const ByteImage& low, ByteImage& img, IO& io) {
    uint8_t* px = img.bytes.data();
    switch (comps) {
    case 1: return detail::walkLevelFast<1>(low, px, img.width, img.height, io);
    case 2: return detail::walkLevelFast<2>(low, px, img.width, img.height, io);
    case 3: return detail::walkLevelFast<3>(low, px, img.width, img.height, io);
    default: return detail::walkLevelFast<4>(low, px, img.width, img.height, io);
    }
}

// The end of a coder 3 to 6 group: the walker's result, then the streams' ends.
template <class IO>
Status finishFast(bool walked, const IO& io, size_t extraBytes, int k) {
    if (!walked)
        return corrupt(fmt::format("level {}: residual error or reconstructed pixel (eq. 3) out "
                                   "of range", k));
    if (!io.finishedCleanly())
        return corrupt(fmt::format("level {}: rANS stream does not end cleanly", k));
    if (!io.bits.exact(extraBytes))
        return corrupt(fmt::format("level {}: extra-bit stream length mismatch", k));
    return Status::ok();
}

// Coder 2 to 6 groups (docs/ptm-format.md): (coder 6: the mode byte, here 0..4,) family table
// counts, tables, rANS stream, extra bits.
Status decodeGroupRans(std::span<const uint8_t> in, const ByteImage* low, ByteImage& img, int k,
                       Coder coder) {
    const bool lowest = k == 0;
    const bool cross = coder == Coder::kPredictCrossRansSimd;
    // coders 4 to 6
    const bool simd = uint8_t(coder) >= uint8_t(Coder::kPredictRansSimd) && !lowest;
    // group 0 of coders 3 to 6 is coder 2's
    const bool fast = coder == Coder::kPredictRansFast && !lowest;
    const uint8_t* p = in.data();
    const uint8_t* end = in.data() + in.size();
    detail::WalkModels models;
    if (coder == Coder::kPredictAboveRansSimd) models = detail::kCoder5Models;
    if (cross) {  // the mode byte (a stored group's never reaches here)
        if (p == end) return corrupt(fmt::format("level {}: truncated before the mode byte", k));
        const int w = *p++;
        const int most = lowest ? 0 : kMaxShapeEighths;
        if (w > most)
            return corrupt(fmt::format("level {}: shape weight {} outside 0..{}", k, w, most));
        models = {true, true, w};
    }
    std::vector<uint16_t> ctxToTable(detail::kMaxRawContexts, 0);
    std::vector<std::array<uint16_t, detail::kTokenCount>> freqs;
    const int families = detail::familyCount(img.channels, lowest);
    if (end - p < families) return corrupt(fmt::format("level {}: truncated context map", k));
    size_t tables = 0;
    // Coders 4 to 6: {first table, g} per family.
    std::array<std::array<int, 2>, 16> familyTables{};
    for (int i = 0; i < families; ++i) {
        const int f = detail::familyId(i, lowest);
        const int raw = detail::familyRawContexts(f & 3);
        const int g = *p++;
        if (g < 1 || g > raw || raw % g != 0)
            return corrupt(fmt::format("level {}: bad table count {} in the context map", k, g));
        for (int q = 0; q < raw; ++q)
            ctxToTable[size_t(f * detail::kFamilyContexts + q)] = uint16_t(tables + size_t(q * g / raw));
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
    const int simdStates = detail::simdStoredStates(img.channels, img.width);
    const uint32_t minBytes = simd ? 4 * uint32_t(simdStates) : fast ? 4 * detail::kFastStates : 8;
    if (ransBytes < minBytes || ransBytes > size_t(end - p) || ransBytes % 2 != 0)
        return corrupt(fmt::format("level {}: rANS stream length {} out of range", k, ransBytes));
    const size_t extraBytes = size_t(end - p) - ransBytes;
    if (simd) {
        // One 32-bit entry per slot (16 KB per table); the walker's contexts are table indices.
        // buildSimdTable writes every entry (a valid table's frequencies sum to kRansTotal).
        uint32_t* entries = simdTableBuffer(tables * detail::kRansTotal);
        for (size_t t = 0; t < tables; ++t)
            detail::buildSimdTable(freqs[t], entries + t * detail::kRansTotal);
        detail::SimdDecodeIO io(entries, familyTables, simdStates, p, p + ransBytes,
                                detail::BitReader(p + ransBytes, end));
        io.models = models;
        if (cross) io.buildSmallAlphabets(freqs, familyTables, img.channels);
        const bool walked = decodeLevelFast(img.channels, *low, img, io);
        return finishFast(walked, io, extraBytes, k);
    }
    if (fast) {
        auto fastTables = std::make_unique<detail::FastTable[]>(tables);
        for (size_t t = 0; t < tables; ++t) detail::buildFastTable(freqs[t], fastTables[t]);
        std::vector<const detail::FastTable*> tableOf(detail::kMaxRawContexts);
        for (size_t q = 0; q < tableOf.size(); ++q) tableOf[q] = &fastTables[ctxToTable[q]];
        detail::FastDecodeIO io(tableOf.data(), p, p + ransBytes,
                                detail::BitReader(p + ransBytes, end));
        const bool walked = decodeLevelFast(img.channels, *low, img, io);
        return finishFast(walked, io, extraBytes, k);
    }
    auto decodeTables = std::make_unique<detail::DecodeTable[]>(tables);
    for (size_t t = 0; t < tables; ++t) detail::buildDecodeTable(freqs[t], decodeTables[t]);
    detail::RansDecodeIO io{decodeTables.get(), ctxToTable.data(),
                            detail::RansDecoder(p, p + ransBytes),
                            detail::BitReader(p + ransBytes, end)};
    bool ok = true;
    if (lowest)
        detail::walkLowestRans(img.bytes.data(), img.width, img.height, img.channels, io);
    else
        ok = detail::walkLevelRansAny(img.channels, *low, img.bytes.data(), img.width, img.height,
                                      io);
    if (!ok)
        return corrupt(fmt::format("level {}: residual error or reconstructed pixel (eq. 3) out "
                                   "of range", k));
    if (!io.rans.finishedCleanly())
        return corrupt(fmt::format("level {}: rANS stream does not end cleanly", k));
    if (!io.bits.exact(extraBytes))
        return corrupt(fmt::format("level {}: extra-bit stream length mismatch", k));
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
    const LevelSize size = mHeader.levelSize(k);
    const int comps = mHeader.components;
    Coder coder = mHeader.coder;
    if (coder == Coder::kPredictCrossRansSimd && !groupBytes.empty() &&
        groupBytes[0] == kStoredGroupMode) {  // coder 6: a stored group is coder 0's
        coder = Coder::kRaw;
        groupBytes = groupBytes.subspan(1);
    }
    if (uint8_t(coder) >= uint8_t(Coder::kPredictRans)) {  // coders 2 to 6
        ByteImage img = levelImage(size, comps);
        PLX_RETURN_IF_ERROR(
            decodeGroupRans(groupBytes, k > 0 ? &mLevels.back() : nullptr, img, k, coder));
        mLevels.push_back(std::move(img));
        return Status::ok();
    }
    const detail::GroupLayout layout = detail::groupLayout(size, comps, k == 0);
    const size_t payloadBytes = layout.payloadBytes();
    std::span<uint8_t> payload;
    if (coder == Coder::kRaw) {
        if (groupBytes.size() != payloadBytes)
            return corrupt(fmt::format("level {} raw group has {} bytes, needs {}", k,
                                       groupBytes.size(), payloadBytes));
        mScratch.assign(groupBytes.begin(), groupBytes.end());
    } else {
        // A zstd frame cannot expand data by more than its block size ratio; a group claiming
        // a payload over 1 GiB more than its own size is refused by the header limits anyway.
        mScratch.resize(payloadBytes);
        PLX_RETURN_IF_ERROR(unzstd(groupBytes, mScratch, k));
    }
    payload = mScratch;
    ByteImage img = levelImage(size, comps);
    const bool predict = coder == Coder::kPredictZstd;
    bool ok = true;
    if (k == 0) {
        if (predict)
            detail::walkLowest<true, false>(img.bytes.data(), size.width, size.height, comps,
                                            payload.data());
        else
            detail::walkLowest<false, false>(img.bytes.data(), size.width, size.height, comps,
                                             payload.data());
    } else if (predict) {
        ok = detail::walkLevelAny<true, false>(comps, mLevels.back(), img.bytes.data(),
                                               size.width, size.height, payload.data());
    } else {
        ok = detail::walkLevelAny<false, false>(comps, mLevels.back(), img.bytes.data(),
                                                size.width, size.height, payload.data());
    }
    if (!ok)
        return corrupt(fmt::format("level {}: residual error or reconstructed pixel (eq. 3) out "
                                   "of range", k));
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
