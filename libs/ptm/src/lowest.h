#pragma once
// Private: group 0 of the modelled coder, the smallest stored level (docs/ptm-format.md, "Group
// 0"): pixels in raster order, components interleaved, each MED-predicted (LOCO-I) and coded in
// a context of its local gradient activity by two interleaved rANS states. Small and not a hot
// loop: only the baseline code runs it. One walker, templated on an IO policy, runs in both
// directions so that encoder and decoder cannot disagree.

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "contexts.h"
#include "rans.h"
#include "streams.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// LOCO-I median edge detector (causal neighbours W, N, NW).
inline int predictMed(int x, int y, int w, int n, int nw) {
    if (x == 0) return y == 0 ? 0 : n;
    if (y == 0) return w;
    const int mx = std::max(w, n), mn = std::min(w, n);
    return nw >= mx ? mn : (nw <= mn ? mx : w + n - nw);
}

// Activity (about 9 absolute residuals) to bucket 0..11, by thresholds on a rough log scale.
struct ActivityLut {
    std::array<uint8_t, 256> q{};
    constexpr ActivityLut() {
        constexpr int kThresholds[kActivityBuckets] = {0, 2, 4, 6, 9, 12, 16, 21, 28, 38, 52, 72};
        for (int a = 0; a < 256; ++a) {
            int b = 0;
            while (b + 1 < kActivityBuckets && a >= kThresholds[b + 1]) ++b;
            q[size_t(a)] = uint8_t(b);
        }
    }
};
inline constexpr ActivityLut kActivity{};
inline int activityBucket(int act) { return kActivity.q[size_t(std::min(act, 255))]; }

class RansDecoder {
public:
    RansDecoder(const uint8_t* begin, const uint8_t* end) : mWords{begin, end} {
        mX0 = readWord() << 16;
        mX0 |= readWord();
        mX1 = readWord() << 16;
        mX1 |= readWord();
    }
    int decode(const DecodeTable& t) {
        const uint32_t slot = mX0 & (kRansTotal - 1);
        const int tok = t.find(slot);
        uint32_t x = uint32_t(t.freq[tok]) * (mX0 >> kRansPrecision) + slot - t.cum[tok];
        if (x < kRansLow) x = (x << 16) | readWord();
        mX0 = mX1;
        mX1 = x;
        return tok;
    }
    // True when the stream was used up exactly and both states returned to their initial value.
    bool finishedCleanly() const {
        const uint32_t states[2] = {mX0, mX1};
        return mWords.finishedCleanly(states);
    }

private:
    uint32_t readWord() { return mWords.readWord(); }
    WordStream mWords;
    uint32_t mX0 = 0, mX1 = 0;
};

// Encoder IO: reads the pixel, records (context, token) and the extra bits.
struct LowestEncodeIO {
    std::vector<CodedSymbol> symbols;
    BitSink bits;
    explicit LowestEncodeIO(uint8_t* bitBuffer) : bits(bitBuffer) {}
    void pixel(uint8_t* px, int ctx, int pred) {
        const int r = int(int8_t(uint8_t(*px - pred)));
        const TokenSplit s = splitToken(zigzag(r));
        symbols.push_back({uint16_t(ctx), uint8_t(s.token)});
        if (s.bits) bits.put(s.extra, s.bits);
    }
};

// Decoder IO: decodes a token of the context's table, adds the extra bits, writes the pixel.
struct LowestDecodeIO {
    const DecodeTable* tables;
    const uint16_t* ctxToTable;
    RansDecoder rans;
    BitReader bits;
    void pixel(uint8_t* px, int ctx, int pred) {
        const int tok = rans.decode(tables[ctxToTable[ctx]]);
        const uint32_t z = kTokens.base[size_t(tok)] + bits.get(kTokens.bits[size_t(tok)]);
        *px = uint8_t(pred + unzigzag(z));
    }
};

// Walks group 0 (the smallest level, width x height x comps).
template <class IO>
void walkLowest(uint8_t* pixels, int width, int height, int comps, IO& io) {
    const size_t stride = size_t(width) * comps;
    for (int y = 0; y < height; ++y) {
        uint8_t* row = pixels + size_t(y) * stride;
        const uint8_t* up = y > 0 ? row - stride : row;
        for (int x = 0; x < width; ++x) {
            for (int c = 0; c < comps; ++c) {
                const size_t i = size_t(x) * comps + c;
                const int w = x > 0 ? row[i - comps] : (y > 0 ? up[i] : 0);
                const int nv = y > 0 ? up[i] : w;
                const int nw = x > 0 && y > 0 ? up[i - comps] : nv;
                const int ne = x + 1 < width && y > 0 ? up[i + comps] : nv;
                const int pred = predictMed(x, y, w, nv, nw);
                const int act = std::abs(w - nw) + std::abs(nv - nw) + std::abs(nv - ne);
                io.pixel(row + i, (4 * c) * kFamilyContexts + activityBucket(3 * act), pred);
            }
        }
    }
}


}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
