#include <fmt/format.h>
#include <zstd.h>

#include <plx/ptm/encoder.h>

#include <cmath>
#include <span>
#include <type_traits>

#include "codec.h"
#include "ctx_codec.h"
#include "fast_codec.h"
#include "simd_codec.h"

namespace plx::ptm {
namespace {

// The uncompressed payload of group k (layout in codec.h).
std::vector<uint8_t> buildPayload(const std::vector<ByteImage>& chain, int k, Coder coder) {
    ByteImage level = chain[size_t(k)];  // the walker's encode mode reads but takes a mutable ptr
    const detail::GroupLayout layout =
        detail::groupLayout({level.width, level.height}, level.channels, k == 0);
    std::vector<uint8_t> payload(layout.payloadBytes(), 0);
    const bool predict = coder == Coder::kPredictZstd;
    if (k == 0) {
        if (predict)
            detail::walkLowest<true, true>(level.bytes.data(), level.width, level.height,
                                           level.channels, payload.data());
        else
            detail::walkLowest<false, true>(level.bytes.data(), level.width, level.height,
                                            level.channels, payload.data());
    } else if (predict) {
        detail::walkLevelAny<true, true>(level.channels, chain[size_t(k - 1)], level.bytes.data(),
                                         level.width, level.height, payload.data());
    } else {
        detail::walkLevelAny<false, true>(level.channels, chain[size_t(k - 1)],
                                          level.bytes.data(), level.width, level.height,
                                          payload.data());
    }
    return payload;
}

// Estimated bits of coding `count` with the normalised table plus the table itself.
double tableCost(const std::array<uint32_t, detail::kTokenCount>& count) {
    const auto freq = detail::normalizeCounts(count);
    double bits = 8.0 * double(detail::tableBytes(freq));
    for (int t = 0; t < detail::kTokenCount; ++t)
        if (count[size_t(t)])
            bits += double(count[size_t(t)]) *
                    (detail::kRansPrecision - std::log2(double(freq[size_t(t)])));
    return bits;
}

// Coder 2 group (docs/ptm-format.md): per family the number g of tables its raw contexts are
// merged into (raw context q uses table q * g / raw), chosen to minimise the estimated size;
// the tables; the rANS stream's length (u32) and bytes; the extra bits.
// Coder 3 (groups k >= 1) differs only in the walker and the four-state rANS stream.
template <class IO>
void walkForEncode(const std::vector<ByteImage>& chain, int k, ByteImage& level, IO& io) {
    if constexpr (std::is_same_v<IO, detail::FastEncodeIO>) {
        const ByteImage& low = chain[size_t(k - 1)];
        uint8_t* px = level.bytes.data();
        switch (level.channels) {
        case 1: detail::walkLevelFast<1>(low, px, level.width, level.height, io); break;
        case 2: detail::walkLevelFast<2>(low, px, level.width, level.height, io); break;
        case 3: detail::walkLevelFast<3>(low, px, level.width, level.height, io); break;
        default: detail::walkLevelFast<4>(low, px, level.width, level.height, io); break;
        }
    } else if (k == 0) {
        detail::walkLowestRans(level.bytes.data(), level.width, level.height, level.channels, io);
    } else {
        detail::walkLevelRansAny(level.channels, chain[size_t(k - 1)], level.bytes.data(),
                                 level.width, level.height, io);
    }
}

// A group up to its rANS stream: the walker's symbols and extra bits, the context map and
// tables (`head`), and the group's estimated size in bits (tables, symbols at their table's
// cost, extra bits), which lets the encoder compare candidates without coding them.
template <class IO>
struct ModelledGroup {
    IO io;
    std::vector<uint8_t> head;
    std::vector<std::array<uint16_t, detail::kTokenCount>> freqs;
    std::vector<uint16_t> ctxToTable;
    double bits = 0;
    int channels = 0, width = 0;
};

template <class IO>
ModelledGroup<IO> modelGroup(const std::vector<ByteImage>& chain, int k, int lanes,
                             const detail::WalkModels& models) {
    ByteImage level = chain[size_t(k)];
    ModelledGroup<IO> g;
    g.channels = level.channels;
    g.width = level.width;
    IO& io = g.io;
    if constexpr (std::is_same_v<IO, detail::FastEncodeIO>) {
        io.lanes = lanes;
        io.models = models;
    }
    const bool lowest = k == 0;
    walkForEncode(chain, k, level, io);
    using Hist = std::array<uint32_t, detail::kTokenCount>;
    std::vector<Hist> hist(detail::kMaxRawContexts, Hist{});
    for (const auto& s : io.symbols) ++hist[s.ctx][s.token];
    std::vector<uint8_t>& out = g.head;
    g.ctxToTable.assign(detail::kMaxRawContexts, 0);
    const int families = detail::familyCount(level.channels, lowest);
    for (int i = 0; i < families; ++i) {
        const int f = detail::familyId(i, lowest);
        const int raw = detail::familyRawContexts(f & 3);
        auto merged = [&](int groups) {
            std::vector<Hist> m(size_t(groups), Hist{});
            for (int q = 0; q < raw; ++q)
                for (int t = 0; t < detail::kTokenCount; ++t)
                    m[size_t(q * groups / raw)][size_t(t)] +=
                        hist[size_t(f * detail::kFamilyContexts + q)][size_t(t)];
            return m;
        };
        int bestG = 1;
        double bestBits = 0;
        for (int groups = 1; groups <= raw; ++groups) {
            if (raw % groups != 0) continue;
            double bits = 8;
            for (const Hist& h : merged(groups)) bits += tableCost(h);
            if (groups == 1 || bits < bestBits) bestBits = bits, bestG = groups;
        }
        g.bits += bestBits;
        out.push_back(uint8_t(bestG));
        for (int q = 0; q < raw; ++q)
            g.ctxToTable[size_t(f * detail::kFamilyContexts + q)] =
                uint16_t(g.freqs.size() + size_t(q * bestG / raw));
        for (const Hist& h : merged(bestG)) g.freqs.push_back(detail::normalizeCounts(h));
    }
    for (const auto& f : g.freqs) detail::writeTable(out, f);
    g.bits += double(io.bits.bitCount());
    return g;
}

// The whole group: head, rANS length and stream, extra bits.
template <class IO>
std::vector<uint8_t> emitGroup(ModelledGroup<IO>& g, int lanes) {
    std::vector<uint8_t> rans;
    if constexpr (std::is_same_v<IO, detail::FastEncodeIO>)
        rans = detail::ransEncodeLanes(
            g.io.symbols, g.freqs, g.ctxToTable, lanes,
            lanes == detail::kSimdStates ? detail::simdStoredStates(g.channels, g.width) : lanes);
    else
        rans = detail::ransEncode(g.io.symbols, g.freqs, g.ctxToTable);
    std::vector<uint8_t> out = std::move(g.head);
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(rans.size() >> (8 * i)));
    out.insert(out.end(), rans.begin(), rans.end());
    const std::vector<uint8_t> bits = g.io.bits.finish();
    out.insert(out.end(), bits.begin(), bits.end());
    return out;
}

template <class IO>
std::vector<uint8_t> encodeGroupRansWith(const std::vector<ByteImage>& chain, int k,
                                         int lanes = detail::kFastStates,
                                         const detail::WalkModels& models = {}) {
    ModelledGroup<IO> g = modelGroup<IO>(chain, k, lanes, models);
    return emitGroup(g, lanes);
}

// Coder 6's group k >= 1, modelled: the shapes' weight byte, then the group coded with it. The
// encoder tries these weights (eighths of the detail above) and keeps the group whose estimated
// size (ModelledGroup::bits) is the smallest, coding only that one: 0.8986x optipng -o2 over
// the 69 Sponza textures, where 4 alone gives 0.9012x and 3 alone 0.9007x
// (docs/ptm-results.md). shapeEighths >= 0 (EncodeConfig) fixes the weight instead.
constexpr int kShapeCandidates[] = {4, 3, 2, 0};

std::vector<uint8_t> modelledCrossGroup(const std::vector<ByteImage>& chain, int k,
                                        int shapeEighths) {
    using Group = ModelledGroup<detail::FastEncodeIO>;
    const int fixed[] = {shapeEighths};
    const std::span<const int> weights =
        shapeEighths >= 0 ? std::span<const int>(fixed) : std::span<const int>(kShapeCandidates);
    Group best;
    for (int w : weights) {
        Group g = modelGroup<detail::FastEncodeIO>(chain, k, detail::kSimdStates,
                                                   detail::WalkModels{true, true, w});
        g.head.insert(g.head.begin(), uint8_t(w));
        if (best.head.empty() || g.bits < best.bits) best = std::move(g);
    }
    return emitGroup(best, detail::kSimdStates);
}

// Coder 6's group k: modelled (k = 0: mode byte 0, then coder 2's group 0), or stored (mode
// byte kStoredGroupMode, then coder 0's payload) where that is smaller, as on the smallest levels,
// whose tables and rANS states outweigh their pixels.
std::vector<uint8_t> encodeGroupCross(const std::vector<ByteImage>& chain, int k,
                                      int shapeEighths) {
    std::vector<uint8_t> modelled;
    if (k == 0) {
        modelled = encodeGroupRansWith<detail::RansEncodeIO>(chain, 0);
        modelled.insert(modelled.begin(), uint8_t(0));
    } else {
        modelled = modelledCrossGroup(chain, k, shapeEighths);
    }
    std::vector<uint8_t> stored = buildPayload(chain, k, Coder::kRaw);
    if (stored.size() + 1 >= modelled.size()) return modelled;
    stored.insert(stored.begin(), kStoredGroupMode);
    return stored;
}

// Coder 2 everywhere, coders 3 to 6 for groups k >= 1 (4 or kSimdStates rANS states; coders 5
// and 6 with the models that look at the block row above, coder 6 with its own).
std::vector<uint8_t> encodeGroupRans(const std::vector<ByteImage>& chain, int k,
                                     const EncodeConfig& config) {
    const Coder coder = config.coder;
    if (coder == Coder::kPredictCrossRansSimd)
        return encodeGroupCross(chain, k, config.shapeEighths);
    if (k == 0 || coder == Coder::kPredictRans)
        return encodeGroupRansWith<detail::RansEncodeIO>(chain, k);
    if (coder == Coder::kPredictAboveRansSimd)
        return encodeGroupRansWith<detail::FastEncodeIO>(chain, k, detail::kSimdStates,
                                                         detail::kCoder5Models);
    const int lanes = coder == Coder::kPredictRansSimd ? detail::kSimdStates : detail::kFastStates;
    return encodeGroupRansWith<detail::FastEncodeIO>(chain, k, lanes);
}

Result<std::vector<uint8_t>> compress(const std::vector<uint8_t>& payload, int level) {
    std::vector<uint8_t> out(ZSTD_compressBound(payload.size()));
    const size_t n = ZSTD_compress(out.data(), out.size(), payload.data(), payload.size(), level);
    if (ZSTD_isError(n))
        return errorStatus(ErrorCode::kInternal, fmt::format("zstd: {}", ZSTD_getErrorName(n)));
    out.resize(n);
    return out;
}

}  // namespace

int storedLevelCount(int width, int height, const EncodeConfig& config) {
    PLX_CHECK(width >= 1 && height >= 1 && config.lowestMaxSide >= 1);
    int count = 1;
    LevelSize s{width, height};
    while (std::max(s.width, s.height) > config.lowestMaxSide) {
        s = lowerLevelSize(s);
        ++count;
    }
    return count;
}

Result<std::vector<uint8_t>> encode(const ByteImage& image, const EncodeConfig& config) {
    if (image.channels < 1 || image.channels > 4)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("PTM encode: {} channels (need 1-4)", image.channels));
    if (image.width < 1 || image.height < 1 || image.width > kMaxSide ||
        image.height > kMaxSide || int64_t(image.width) * image.height > kMaxPixels)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("PTM encode: size {}x{} outside 1x1..{}x{}", image.width,
                                       image.height, kMaxSide, kMaxSide));
    if (image.bytes.size() != image.rowBytes() * size_t(image.height))
        return errorStatus(ErrorCode::kInvalidArgument, "PTM encode: pixel buffer size mismatch");
    if (config.lowestMaxSide < 1)
        return errorStatus(ErrorCode::kInvalidArgument, "PTM encode: lowestMaxSide must be >= 1");
    if (uint8_t(config.coder) > uint8_t(kLastCoder))
        return errorStatus(ErrorCode::kInvalidArgument, "PTM encode: unknown coder");
    if (config.shapeEighths < -1 || config.shapeEighths > kMaxShapeEighths)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("PTM encode: shape weight {} outside -1..{}",
                                       config.shapeEighths, kMaxShapeEighths));
    if (config.coder == Coder::kPredictZstd &&
        (config.zstdLevel < 1 || config.zstdLevel > ZSTD_maxCLevel()))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("PTM encode: zstd level {} outside 1..{}", config.zstdLevel,
                                       ZSTD_maxCLevel()));
    const int count = storedLevelCount(image.width, image.height, config);
    const std::vector<ByteImage> chain = buildMipChain(image, count);  // eq. (1)
    Header header;
    header.width = image.width;
    header.height = image.height;
    header.components = image.channels;
    header.levelCount = count;
    header.lowest = {chain[0].width, chain[0].height};
    header.coder = config.coder;
    std::vector<std::vector<uint8_t>> groups;
    uint64_t offset = headerBytesFor(count);
    for (int k = 0; k < count; ++k) {
        const bool rans = uint8_t(config.coder) >= uint8_t(Coder::kPredictRans);  // coders 2-6
        std::vector<uint8_t> payload =
            rans ? encodeGroupRans(chain, k, config) : buildPayload(chain, k, config.coder);
        if (config.coder == Coder::kPredictZstd) {
            auto packed = compress(payload, config.zstdLevel);
            if (!packed) return packed.status();
            payload = std::move(packed).value();
        }
        header.groups.push_back({offset, payload.size(), crc32(payload)});
        offset += payload.size();
        groups.push_back(std::move(payload));
    }
    std::vector<uint8_t> file = writeHeader(header);
    file.reserve(offset);
    for (const auto& g : groups) file.insert(file.end(), g.begin(), g.end());
    return file;
}

}  // namespace plx::ptm
