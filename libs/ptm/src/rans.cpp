#include "rans.h"

#include <cstring>

#include <plx/core/check.h>


namespace plx::ptm::detail {

std::array<uint16_t, kTokenCount> normalizeCounts(const std::array<uint32_t, kTokenCount>& c) {
    std::array<uint16_t, kTokenCount> f{};
    uint64_t total = 0;
    for (uint32_t v : c) total += v;
    if (total == 0) return f;
    int sum = 0, largest = 0;
    for (int t = 0; t < kTokenCount; ++t) {
        if (c[size_t(t)] == 0) continue;
        const uint64_t scaled = (uint64_t(c[size_t(t)]) * kRansTotal + total / 2) / total;
        f[size_t(t)] = uint16_t(std::max<uint64_t>(scaled, 1));
        sum += f[size_t(t)];
        if (c[size_t(t)] > c[size_t(largest)]) largest = t;
    }
    // Move the rounding error onto the largest entries, never below 1.
    while (sum != int(kRansTotal)) {
        if (sum < int(kRansTotal)) {
            f[size_t(largest)] = uint16_t(f[size_t(largest)] + (int(kRansTotal) - sum));
            sum = int(kRansTotal);
        } else {
            int best = -1;
            for (int t = 0; t < kTokenCount; ++t)
                if (f[size_t(t)] > 1 && (best < 0 || f[size_t(t)] > f[size_t(best)])) best = t;
            const int take = std::min(sum - int(kRansTotal), int(f[size_t(best)]) - 1);
            f[size_t(best)] = uint16_t(f[size_t(best)] - take);
            sum -= take;
        }
    }
    return f;
}

namespace {
int lastNonZero(const std::array<uint16_t, kTokenCount>& freq) {
    int last = -1;
    for (int t = 0; t < kTokenCount; ++t)
        if (freq[size_t(t)]) last = t;
    return last;
}
}  // namespace

size_t tableBytes(const std::array<uint16_t, kTokenCount>& freq) {
    const int last = lastNonZero(freq);
    size_t n = 1;
    for (int t = 0; t < last; ++t) n += freq[size_t(t)] < 128 ? 1 : 2;
    return n;
}

void writeTable(std::vector<uint8_t>& out, const std::array<uint16_t, kTokenCount>& freq) {
    const int last = lastNonZero(freq);
    out.push_back(uint8_t(last + 1));
    for (int t = 0; t < last; ++t) {
        const unsigned v = freq[size_t(t)];
        if (v < 128) {
            out.push_back(uint8_t(v));
        } else {
            out.push_back(uint8_t(0x80 | (v & 0x7F)));
            out.push_back(uint8_t(v >> 7));
        }
    }
}

bool readTable(const uint8_t*& p, const uint8_t* end, std::array<uint16_t, kTokenCount>& freq) {
    freq.fill(0);
    if (p >= end) return false;
    const int count = *p++;
    if (count > kTokenCount) return false;
    if (count == 0) return true;
    unsigned sum = 0;
    for (int t = 0; t + 1 < count; ++t) {
        if (p >= end) return false;
        unsigned v = *p++;
        if (v & 0x80) {
            if (p >= end || *p >= 0x40) return false;  // frequencies are < 2^13
            v = (v & 0x7F) | unsigned(*p++) << 7;
        }
        sum += v;
        if (sum >= kRansTotal) return false;  // the implied last frequency must be >= 1
        freq[size_t(t)] = uint16_t(v);
    }
    freq[size_t(count - 1)] = uint16_t(kRansTotal - sum);
    return true;
}

void buildDecodeTable(const std::array<uint16_t, kTokenCount>& freq, DecodeTable& t) {
    unsigned cum = 0;
    for (int s = 0; s < 32; ++s) {
        const unsigned f = s < kTokenCount ? freq[size_t(s)] : 0;
        t.freq[s] = uint16_t(f);
        t.cum[s] = uint16_t(s < kTokenCount && (f > 0 || cum < kRansTotal) ? cum : 0xFFFF);
        cum += f;
    }
    if (cum == 0) {  // empty table: token 0 everywhere, the state unchanged
        t.freq[0] = uint16_t(kRansTotal);
        for (int s = 1; s < 32; ++s) t.cum[s] = 0xFFFF;
    }
}

namespace {
// Cumulative frequencies (exclusive prefix sums) of each table, for the encoders.
std::vector<std::array<uint16_t, kTokenCount>> cumulativeFrequencies(
    const std::vector<std::array<uint16_t, kTokenCount>>& freqs) {
    std::vector<std::array<uint16_t, kTokenCount>> cums(freqs.size());
    for (size_t i = 0; i < freqs.size(); ++i) {
        unsigned c = 0;
        for (int t = 0; t < kTokenCount; ++t) {
            cums[i][size_t(t)] = uint16_t(c);
            c += freqs[i][size_t(t)];
        }
    }
    return cums;
}
}  // namespace

std::vector<uint8_t> ransEncode(std::span<const CodedSymbol> symbols,
                                const std::vector<std::array<uint16_t, kTokenCount>>& freqs,
                                const std::vector<uint16_t>& ctxToTable) {
    const auto cums = cumulativeFrequencies(freqs);
    std::vector<uint16_t> words;
    words.reserve(symbols.size() / 2 + 8);
    uint32_t x[2] = {kRansLow, kRansLow};
    for (size_t i = symbols.size(); i-- > 0;) {
        const CodedSymbol& s = symbols[i];
        const size_t table = ctxToTable[s.ctx];
        const uint32_t f = freqs[table][s.token], c = cums[table][s.token];
        uint32_t& st = x[i & 1];
        if (uint64_t(st) >= (uint64_t(f) << (32 - kRansPrecision))) {  // state stays < 2^32
            words.push_back(uint16_t(st & 0xFFFF));
            st >>= 16;
        }
        st = ((st / f) << kRansPrecision) + (st % f) + c;
    }
    std::vector<uint8_t> out;
    out.reserve(8 + 2 * words.size());
    auto putWord = [&](uint32_t w) {
        out.push_back(uint8_t(w & 0xFF));
        out.push_back(uint8_t(w >> 8));
    };
    putWord(x[0] >> 16);
    putWord(x[0] & 0xFFFF);
    putWord(x[1] >> 16);
    putWord(x[1] & 0xFFFF);
    for (size_t i = words.size(); i-- > 0;) putWord(words[i]);
    return out;
}

std::vector<uint8_t> ransEncodeLanes(std::span<const LaneSymbol> symbols,
                                     const std::vector<std::array<uint16_t, kTokenCount>>& freqs,
                                     const std::vector<uint16_t>& ctxToTable, int stored) {
    constexpr int lanes = kSimdStates;
    const auto cums = cumulativeFrequencies(freqs);
    std::vector<uint16_t> words;
    words.reserve(symbols.size() / 2 + 8);
    std::vector<uint32_t> x(size_t(lanes), kRansLow);
    for (size_t i = symbols.size(); i-- > 0;) {
        const LaneSymbol& s = symbols[i];
        const size_t table = ctxToTable[s.ctx];
        const uint32_t f = freqs[table][s.token], c = cums[table][s.token];
        uint32_t& st = x[s.lane];
        if (uint64_t(st) >= (uint64_t(f) << (32 - kRansPrecision))) {  // state stays < 2^32
            words.push_back(uint16_t(st & 0xFFFF));
            st >>= 16;
        }
        st = ((st / f) << kRansPrecision) + (st % f) + c;
    }
    std::vector<uint8_t> out;
    out.reserve(4 * size_t(stored) + 2 * words.size());
    auto putWord = [&](uint32_t w) {
        out.push_back(uint8_t(w & 0xFF));
        out.push_back(uint8_t(w >> 8));
    };
    for (int l = 0; l < lanes; ++l) {
        if (l >= stored) {
            PLX_CHECK(x[size_t(l)] == kRansLow);  // an unused lane (not stored)
            continue;
        }
        putWord(x[size_t(l)] >> 16);
        putWord(x[size_t(l)] & 0xFFFF);
    }
    for (size_t i = words.size(); i-- > 0;) putWord(words[i]);
    return out;
}

}  // namespace plx::ptm::detail
