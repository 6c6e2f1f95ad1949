#include <fmt/format.h>

#include <plx/ptm/encoder.h>

#include <cmath>
#include <memory>
#include <span>

#include "kernels.h"
#include "lowest.h"
#include "raw_layout.h"

namespace plx::ptm {
namespace {

// Coder kRaw's payload of group k (layout in raw_layout.h).
std::vector<uint8_t> rawPayload(const std::vector<ByteImage>& chain, int k) {
    const ByteImage& level = chain[size_t(k)];
    const detail::GroupLayout layout =
        detail::groupLayout({level.width, level.height}, level.channels, k == 0);
    std::vector<uint8_t> payload(layout.payloadBytes(), 0);
    // The walker takes the pixels mutable for decoding; encoding only reads them.
    uint8_t* px = const_cast<uint8_t*>(level.bytes.data());
    if (k == 0)
        detail::walkRawLowest<true>(px, level.width, level.height, level.channels,
                                    payload.data());
    else
        detail::walkRawLevelAny<true>(level.channels, chain[size_t(k - 1)], px, level.width,
                                      level.height, payload.data());
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

// A group's walk: its symbols (Symbol: CodedSymbol in group 0, LaneSymbol in the others) and
// extra bits.
template <class Symbol>
struct GroupTokens {
    std::vector<Symbol> symbols;
    std::vector<uint8_t> bits;
    size_t bitCount = 0;
};

// Group 0: the smallest level (lowest.h).
GroupTokens<detail::CodedSymbol> walkLowestTokens(const ByteImage& level) {
    const size_t pixels = size_t(level.width) * size_t(level.height) * size_t(level.channels);
    GroupTokens<detail::CodedSymbol> t;
    t.bits.resize(detail::maxExtraBytes(pixels));
    detail::LowestEncodeIO io(t.bits.data());
    io.symbols.reserve(pixels);
    // The walker takes the pixels mutable for decoding; encoding only reads them.
    detail::walkLowest(const_cast<uint8_t*>(level.bytes.data()), level.width, level.height,
                       level.channels, io);
    t.symbols = std::move(io.symbols);
    t.bitCount = io.bits.bitCount();
    t.bits.resize(io.bits.finish());
    return t;
}

// Group k >= 1 with shape weight w: the level walker of the active ISA (kernels.h).
GroupTokens<detail::LaneSymbol> walkLevelTokens(const std::vector<ByteImage>& chain, int k,
                                                int w) {
    const ByteImage& lower = chain[size_t(k - 1)];
    const size_t most = detail::maxLevelSymbols(lower);
    auto symbols = std::make_unique_for_overwrite<detail::LaneSymbol[]>(most);
    GroupTokens<detail::LaneSymbol> t;
    t.bits.resize(detail::maxExtraBytes(most));
    using namespace detail;
    const LevelTokens n =
        PLX_ISA_PICK(encodeLevel)(lower, chain[size_t(k)], w, symbols.get(), t.bits.data());
    t.symbols.assign(symbols.get(), symbols.get() + n.symbols);
    t.bitCount = n.bitCount;
    t.bits.resize(n.bitBytes);
    return t;
}

// A group up to its rANS stream: the walker's tokens, the mode byte, context map and tables
// (`head`), and the group's estimated size in bits (tables, symbols at their table's cost,
// extra bits), which lets the encoder compare candidates without coding them.
template <class Symbol>
struct ModelledGroup {
    GroupTokens<Symbol> tokens;
    std::vector<uint8_t> head;
    std::vector<std::array<uint16_t, detail::kTokenCount>> freqs;
    std::vector<uint16_t> ctxToTable;
    double bits = 0;
};

// Per family the number g of tables its raw contexts are merged into (raw context q uses table
// q * g / raw), chosen to minimise the estimated size; then the tables.
template <class Symbol>
ModelledGroup<Symbol> modelGroup(GroupTokens<Symbol> tokens, int comps, bool lowest,
                                 uint8_t mode) {
    ModelledGroup<Symbol> g;
    g.tokens = std::move(tokens);
    using Hist = std::array<uint32_t, detail::kTokenCount>;
    std::vector<Hist> hist(detail::kMaxRawContexts, Hist{});
    for (const auto& s : g.tokens.symbols) ++hist[s.ctx][s.token];
    std::vector<uint8_t>& out = g.head;
    out.push_back(mode);
    g.ctxToTable.assign(detail::kMaxRawContexts, 0);
    const int families = detail::familyCount(comps, lowest);
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
    g.bits += double(g.tokens.bitCount);
    return g;
}

// The whole group: head, rANS length and stream, extra bits.
std::vector<uint8_t> emitGroup(std::vector<uint8_t> out, const std::vector<uint8_t>& rans,
                               const std::vector<uint8_t>& bits) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(rans.size() >> (8 * i)));
    out.insert(out.end(), rans.begin(), rans.end());
    out.insert(out.end(), bits.begin(), bits.end());
    return out;
}

// Group k >= 1, modelled: the encoder tries these shape weights (eighths of the detail above)
// and keeps the group whose estimated size (ModelledGroup::bits) is the smallest, coding only
// that one (docs/ptm-format.md, "Encoder"). shapeEighths >= 0 (EncodeConfig) fixes the weight.
constexpr int kShapeCandidates[] = {4, 3, 2, 0};

std::vector<uint8_t> modelledLevelGroup(const std::vector<ByteImage>& chain, int k,
                                        int shapeEighths) {
    using Group = ModelledGroup<detail::LaneSymbol>;
    const int fixed[] = {shapeEighths};
    const std::span<const int> weights =
        shapeEighths >= 0 ? std::span<const int>(fixed) : std::span<const int>(kShapeCandidates);
    const ByteImage& level = chain[size_t(k)];
    Group best;
    for (int w : weights) {
        Group g = modelGroup(walkLevelTokens(chain, k, w), level.channels, false, uint8_t(w));
        if (best.head.empty() || g.bits < best.bits) best = std::move(g);
    }
    const auto rans =
        detail::ransEncodeLanes(best.tokens.symbols, best.freqs, best.ctxToTable,
                                detail::simdStoredStates(level.channels, level.width));
    return emitGroup(std::move(best.head), rans, best.tokens.bits);
}

// Group 0, modelled: mode byte 0, then the smallest level by two rANS states.
std::vector<uint8_t> modelledLowestGroup(const ByteImage& level) {
    auto g = modelGroup(walkLowestTokens(level), level.channels, true, 0);
    const auto rans = detail::ransEncode(g.tokens.symbols, g.freqs, g.ctxToTable);
    return emitGroup(std::move(g.head), rans, g.tokens.bits);
}

// Coder kRans's group k: modelled, or stored (mode byte kStoredGroupMode, then coder kRaw's
// payload) where that is smaller, as on the smallest levels, whose tables and rANS states
// outweigh their pixels.
std::vector<uint8_t> encodeGroupRans(const std::vector<ByteImage>& chain, int k,
                                     int shapeEighths) {
    std::vector<uint8_t> modelled = k == 0 ? modelledLowestGroup(chain[0])
                                           : modelledLevelGroup(chain, k, shapeEighths);
    std::vector<uint8_t> stored = rawPayload(chain, k);
    if (stored.size() + 1 >= modelled.size()) return modelled;
    stored.insert(stored.begin(), kStoredGroupMode);
    return stored;
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
        std::vector<uint8_t> payload = config.coder == Coder::kRans
                                           ? encodeGroupRans(chain, k, config.shapeEighths)
                                           : rawPayload(chain, k);
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
