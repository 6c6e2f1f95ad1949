#pragma once
// Private: Coder::kPredictRans (docs/ptm-format.md, "Coder 2"). One walker, templated on an IO
// policy, runs in both directions so that encoder and decoder cannot disagree: the encoder's IO
// reads the pixel and records a token, the decoder's IO decodes a token and writes the pixel.
//
// Group k >= 1: blocks in raster order; per block, for each stored position (p00, p10, p01) and
// component the prediction residual of the block-sum predictor (codec.h), then per component the
// residual error eps of eq. (3) (not coded where n = 1: it is 0). The last pixel of the block
// follows from eq. (3). Contexts: the stored position and component, and the quantised activity
// (sum of absolute prediction residuals) of the already decoded neighbouring blocks of the same
// level, the pixels already decoded in the block and the previous component at the same pixel.
// eps is coded in the context of the block sum that the planar prediction p11 ~ p10 + p01 - p00
// implies, so it costs well under 2 bits where the texture is smooth.

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include <plx/core/image.h>

#include "codec.h"
#include "rans.h"

namespace plx::ptm::detail {

// Context layout: family f (16 raw contexts each) = 4 * component + kind, kind 0..2 the stored
// positions p00, p10, p01 (or the smallest level's pixels, kind 0 of group 0), kind 3 eps.
inline constexpr int kFamilyContexts = 16;
inline constexpr int kActivityBuckets = 12;  // raw pixel contexts per family
inline constexpr int kEpsContexts = 16;      // raw eps contexts per family
inline constexpr int kMaxRawContexts = 16 * kFamilyContexts;

// Raw contexts of family kind (pixel families have 12, eps families 16).
inline int familyRawContexts(int kind) { return kind == 3 ? kEpsContexts : kActivityBuckets; }

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

// Encoder IO: reads the pixel, records (context, token) and the extra bits.
struct RansEncodeIO {
    static constexpr bool kEncode = true;
    std::vector<CodedSymbol> symbols;
    BitWriter bits;
    int pixel(uint8_t* px, int ctx, int pred) {
        const int r = int(int8_t(uint8_t(*px - pred)));
        const TokenSplit s = splitToken(zigzag(r));
        symbols.push_back({uint16_t(ctx), uint8_t(s.token)});
        if (s.bits) bits.put(s.extra, s.bits);
        return r < 0 ? -r : r;
    }
    int eps(int ctx, int value) {
        symbols.push_back({uint16_t(ctx), uint8_t(value)});
        return value;
    }
};

// Decoder IO: decodes a token of the context's table, adds the extra bits, writes the pixel.
struct RansDecodeIO {
    static constexpr bool kEncode = false;
    const DecodeTable* tables;
    const uint16_t* ctxToTable;
    RansDecoder rans;
    BitReader bits;
    int pixel(uint8_t* px, int ctx, int pred) {
        const int tok = rans.decode(tables[ctxToTable[ctx]]);
        const uint32_t z = kTokens.base[size_t(tok)] + bits.get(kTokens.bits[size_t(tok)]);
        const int r = unzigzag(z);
        *px = uint8_t(pred + r);
        return r < 0 ? -r : r;
    }
    int eps(int ctx, int /*value*/) { return rans.decode(tables[ctxToTable[ctx]]); }
};

// Per block and component: activity and the summed absolute errors of sub-predictors A and B.
struct BlockStats {
    uint16_t act = 0;
    uint16_t errA = 0;
    uint16_t errB = 0;
};

// Sub-predictor A (block sum, parent level), B (A plus the previous component's A residual) or their rounded mean.
inline int choose(int sel, int pA, int pB) {
    return sel == 0 ? pA : (sel == 1 ? pB : (pA + pB + 1) >> 1);
}

// Group k >= 1. Returns false (decode only) on an eps >= n or a pixel of eq. (3) outside 0..255.
template <int C, class IO>
bool walkLevelRans(const ByteImage& low, uint8_t* cur, int width, int height, IO& ioRef) {
    // A local copy whose address does not escape: the pixel stores (uint8_t may alias anything)
    // then do not force the coder state out of registers.
    IO io = std::move(ioRef);
    const size_t stride = size_t(width) * C, lowStride = size_t(low.width) * C;
    // Per block and component, of the previous and the current block row: the activity (sum of
    // |residual| over the block's stored pixels) and the errors of the two sub-predictors;
    // entries 0 and lw + 1 replicate the row's ends.
    const size_t rowLen = size_t(low.width + 2) * C;
    std::vector<BlockStats> statRows(2 * rowLen);
    unsigned bad = 0;
    for (int by = 0; by < low.height; ++by) {
        BlockStats* prev = statRows.data() + size_t((by + 1) & 1) * rowLen;
        BlockStats* row = statRows.data() + size_t(by & 1) * rowLen;
        const int y0 = 2 * by, y1 = std::min(y0 + 1, height - 1);
        uint8_t* r0 = cur + size_t(y0) * stride;
        uint8_t* r1 = cur + size_t(y1) * stride;
        const uint8_t* lm = low.bytes.data() + size_t(by) * lowStride;
        const uint8_t* lu = low.bytes.data() + size_t(std::max(by - 1, 0)) * lowStride;
        const uint8_t* ld = low.bytes.data() + size_t(std::min(by + 1, low.height - 1)) * lowStride;
        for (int bx = 0; bx < low.width; ++bx) {
            const int x0 = 2 * bx, x1 = std::min(x0 + 1, width - 1);
            const int nx = x1 > x0 ? 2 : 1, ny = y1 > y0 ? 2 : 1, n = nx * ny;
            const size_t xl = size_t(std::max(bx - 1, 0)) * C, xm = size_t(bx) * C;
            const size_t xr = size_t(std::min(bx + 1, low.width - 1)) * C;
            const BlockStats* pa = prev + size_t(bx + 1) * C;  // the block above
            BlockStats* ra = row + size_t(bx + 1) * C;         // this block
            int act[C], sel[C];
            for (int c = 0; c < C; ++c) {
                const BlockStats zero{};
                const BlockStats& left = bx > 0 ? ra[c - C] : (by > 0 ? pa[c] : zero);
                const BlockStats& up = by > 0 ? pa[c] : left;
                const BlockStats& ul = by > 0 ? pa[c - C] : left;
                const BlockStats& ur = by > 0 ? pa[c + C] : left;
                act[c] = left.act + up.act + ((ul.act + ur.act) >> 1);
                const int ea = left.errA + up.errA + ((ul.errA + ur.errA) >> 1);
                const int eb = left.errB + up.errB + ((ul.errB + ur.errB) >> 1);
                // Sub-predictor choice by the neighbours' errors: A, B, or their mean.
                sel[c] = eb < ea ? 1 : 0;
                if (c == 0) sel[c] = 0;  // B needs the previous component
            }
            int e0[C], e1[C], e2[C];
            int a[C], b[C], d[C];
            uint8_t* pp[4];
            pp[0] = r0 + size_t(x0) * C;
            pp[1] = r0 + size_t(x1) * C;
            pp[2] = r1 + size_t(x0) * C;
            pp[3] = r1 + size_t(x1) * C;
            int u[4][C];
            for (int c = 0; c < C; ++c) {
                const int m = lm[xm + c];
                const int l = lm[xl + c], r = lm[xr + c], upv = lu[xm + c], dn = ld[xm + c];
                u[0][c] = upsample(m, l, upv, lu[xl + c]);
                u[1][c] = upsample(m, r, upv, lu[xr + c]);
                u[2][c] = upsample(m, l, dn, ld[xl + c]);
                u[3][c] = upsample(m, r, dn, ld[xr + c]);
            }
            if (n == 4) {
                int errA[C], errB[C], res[C];
                for (int c = 0; c < C; ++c) {
                    const int m = lm[xm + c];
                    const int pA = predictBlockPixel(4, m, 0, u[0][c] + u[1][c] + u[2][c] +
                                                     u[3][c], 4, u[0][c]);
                    const int pB = c > 0 ? std::clamp(pA + res[c - 1], 0, 255) : pA;
                    int ac = act[c];
                    (void)0;
                    e0[c] = io.pixel(pp[0] + c, (4 * c) * kFamilyContexts + activityBucket(ac),
                                     choose(sel[c], pA, pB));
                    a[c] = pp[0][c];
                    res[c] = a[c] - pA;
                    errA[c] = std::abs(a[c] - pA);
                    errB[c] = std::abs(a[c] - pB);
                }
                for (int c = 0; c < C; ++c) {
                    const int m = lm[xm + c];
                    const int pA = predictBlockPixel(4, m, a[c], u[1][c] + u[2][c] + u[3][c], 3,
                                                     u[1][c]);
                    const int pB = c > 0 ? std::clamp(pA + res[c - 1], 0, 255) : pA;
                    int ac = (act[c] + 5 * e0[c]) >> 1;
                    (void)0;
                    e1[c] = io.pixel(pp[1] + c,
                                     (4 * c + 1) * kFamilyContexts + activityBucket(ac),
                                     choose(sel[c], pA, pB));
                    b[c] = pp[1][c];
                    res[c] = b[c] - pA;
                    errA[c] += std::abs(b[c] - pA);
                    errB[c] += std::abs(b[c] - pB);
                }
                for (int c = 0; c < C; ++c) {
                    const int m = lm[xm + c];
                    const int pA = predictBlockPixel(4, m, a[c] + b[c], u[2][c] + u[3][c], 2,
                                                     u[2][c]);
                    const int pB = c > 0 ? std::clamp(pA + res[c - 1], 0, 255) : pA;
                    int ac = (act[c] + 3 * (e0[c] + e1[c])) >> 1;
                    (void)0;
                    e2[c] = io.pixel(pp[2] + c,
                                     (4 * c + 2) * kFamilyContexts + activityBucket(ac),
                                     choose(sel[c], pA, pB));
                    d[c] = pp[2][c];
                    res[c] = d[c] - pA;
                    errA[c] += std::abs(d[c] - pA);
                    errB[c] += std::abs(d[c] - pB);
                }
                for (int c = 0; c < C; ++c) {
                    const int m = lm[xm + c];
                    // Planar prediction of p11 gives a predicted block sum 2 (b + d) - 4 m + eps.
                    const int sHat = std::clamp(2 * (b[c] + d[c]) - 4 * m, -2, 4);
                    const int smooth = act[c] + e0[c] + e1[c] + e2[c] < 12 ? 0 : 1;
                    const int ctx = (4 * c + 3) * kFamilyContexts + (sHat + 2) * 2 + smooth;
                    int ep = 0;
                    if constexpr (IO::kEncode) ep = a[c] + b[c] + d[c] + pp[3][c] - 4 * m;
                    ep = io.eps(ctx, ep);
                    const int last = 4 * m + ep - a[c] - b[c] - d[c];
                    if constexpr (!IO::kEncode) {
                        bad |= unsigned(ep >= 4) | unsigned(unsigned(last) > 255u);
                        pp[3][c] = uint8_t(last);
                    }
                    ra[c] = {uint16_t(e0[c] + e1[c] + e2[c]), uint16_t(errA[c]),
                             uint16_t(errB[c])};
                }
            } else if (n == 2) {
                // A 2x1 or 1x2 block: p00 coded, eps in {0, 1}, the other pixel by eq. (3).
                uint8_t* other = nx == 2 ? pp[1] : pp[2];
                const int uo = nx == 2 ? 1 : 2;
                for (int c = 0; c < C; ++c) {
                    const int m = lm[xm + c];
                    const int pred =
                        predictBlockPixel(2, m, 0, u[0][c] + u[uo][c], 2, u[0][c]);
                    int ac = act[c];
                    (void)0;
                    e0[c] = io.pixel(pp[0] + c, (4 * c) * kFamilyContexts + activityBucket(ac),
                                     pred);
                    const int ctx = (4 * c + 3) * kFamilyContexts + kEpsContexts - 2;
                    int ep = 0;
                    if constexpr (IO::kEncode) ep = pp[0][c] + other[c] - 2 * m;
                    ep = io.eps(ctx, ep);
                    const int last = 2 * m + ep - pp[0][c];
                    if constexpr (!IO::kEncode) {
                        bad |= unsigned(ep >= 2) | unsigned(unsigned(last) > 255u);
                        other[c] = uint8_t(last);
                    }
                    ra[c] = {uint16_t(3 * e0[c]), uint16_t(3 * e0[c]), uint16_t(3 * e0[c] + 3)};
                }
            } else {
                for (int c = 0; c < C; ++c) {
                    if constexpr (!IO::kEncode) pp[0][c] = lm[xm + c];  // n = 1: eps = 0
                    ra[c] = {};
                }
            }
        }
        for (int c = 0; c < C; ++c) {  // replicate the row's ends for the next row's diagonals
            row[c] = row[C + c];
            row[size_t(low.width + 1) * C + c] = row[size_t(low.width) * C + c];
        }
    }
    ioRef = std::move(io);
    return bad == 0;
}

// Group 0: the smallest level, MED-predicted, contexts by the local gradient activity.
template <class IO>
void walkLowestRans(uint8_t* pixels, int width, int height, int comps, IO& io) {
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

// Runtime component count to the walker's template argument.
template <class IO>
bool walkLevelRansAny(int comps, const ByteImage& low, uint8_t* cur, int w, int h, IO& io) {
    switch (comps) {
    case 1: return walkLevelRans<1>(low, cur, w, h, io);
    case 2: return walkLevelRans<2>(low, cur, w, h, io);
    case 3: return walkLevelRans<3>(low, cur, w, h, io);
    default: return walkLevelRans<4>(low, cur, w, h, io);
    }
}

// Families present in a group: group 0 has one per component (kind 0), others four.
inline int familyCount(int comps, bool lowest) { return lowest ? comps : 4 * comps; }
inline int familyId(int i, bool lowest) { return lowest ? 4 * i : i; }

}  // namespace plx::ptm::detail
