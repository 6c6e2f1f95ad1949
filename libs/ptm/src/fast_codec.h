#pragma once
// Private: Coder::kPredictRansFast (docs/ptm-format.md, "Coder 3"). Same information as coder 2
// (the residual errors of eq. 3 and three pixels per 2x2 block), coded so that decoding splits
// into passes without a per-symbol dependency on freshly decoded pixels:
//
// - per block row, the tokens come in *runs*: p00 of every full block (component-major), then
//   p10, then p01, then eps; each run's contexts depend only on the previous block row, the
//   lower level and the runs already decoded in this row, so the whole run's contexts are
//   computed first and the entropy decoder is a tight loop of table look-ups;
// - the pixels are then rebuilt from the residuals in a separate loop over the row's blocks
//   (block-sum predictor, inter-component sub-predictor, eq. 3), with no dependency between
//   blocks of a row;
// - four interleaved rANS states; symbol j of a run uses state j mod 4.
//
// Coders 4 to 6 reuse this walker (32 states, simd_codec.h); coder 6 walks each block row
// component by component instead (walkFullRowByComponent), so that a component's predictions and
// contexts can also use the components before it in the same block.
//
// One walker, templated on an IO policy, runs in both directions (the encoder's IO records the
// tokens of a run, the decoder's IO decodes them), so the two cannot disagree.

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__AVX2__)
#include <immintrin.h>
#endif
// AVX-512 paths (F, BW and VL, as AMD Zen 4 and later and Intel's server cores have): where the
// build targets such a CPU (-march=native on one), they replace the AVX2 ones they extend.
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)
#define PLX_PTM_AVX512 1
#else
#define PLX_PTM_AVX512 0
#endif

#include <plx/core/image.h>
#include <plx/ptm/format.h>

#include "codec.h"
#include "ctx_codec.h"
#include "rans.h"

// Loop hints: rows of different arrays never overlap (ivdep); keep the rANS states scalar.
#if defined(__clang__)  // the fuzzing build; no hints (clang warns where it cannot follow them)
#define PLX_PTM_IVDEP
#define PLX_PTM_NO_SLP
#else
#define PLX_PTM_IVDEP _Pragma("GCC ivdep")
#define PLX_PTM_NO_SLP __attribute__((optimize("no-tree-slp-vectorize")))
#endif

namespace plx::ptm::detail {

inline constexpr int kFastStates = 4;

// Which of the walker's optional models a group uses (docs/ptm-format.md, coders 5 and 6).
struct WalkModels {
    // Coders 5, 6: the block row above in the upper pixels' shapes and in the eps contexts.
    bool above = false;
    // Coder 6: component-major block rows, so that a component's predictions and contexts see
    // the components before it in the same block (inter-component p11, the mean of two earlier
    // components' residuals, their magnitudes in the contexts).
    bool cross = false;
    // Weight of the detail above in the shapes of p00 and p10, in eighths (coder 5: 4; coder 6:
    // 0..kMaxShapeEighths, chosen per group by the encoder).
    int shapeEighths = 4;
};
inline constexpr WalkModels kCoder5Models{true, false, 4};

// Raw context id (family 4c + kind, raw context q), as coder 2.
inline int rawCtx(int c, int kind, int q) { return (4 * c + kind) * kFamilyContexts + q; }

// The context ids a walker writes for family (c, kind): raw context q becomes
// `base + ((q * mul) >> 13)`. The encoder and coder 3's decoder use the raw ids (base =
// rawCtx(c, kind, 0), mul = 8192); coder 4's decoder maps straight to the family's table index
// `first + q * g / R` of the context map (exact with mul = 683 g for R = 12, q * g <= 132, and
// mul = 512 g for R = 16).
struct CtxMap {
    int base = 0;
    int mul = 8192;
    int operator()(int q) const { return base + ((q * mul) >> 13); }
};
inline CtxMap rawCtxMap(int c, int kind) { return {rawCtx(c, kind, 0), 8192}; }

// Decode table of one context for coder 3: the token of every 12-bit slot (one load per symbol)
// and per token its frequency (low 16 bits) and cumulative start (high 16 bits).
struct FastTable {
    uint8_t sym[kRansTotal];
    uint32_t freqCum[32];
};
// Fills t from freq (sum kRansTotal, or all zero: then every slot decodes token 0 with
// frequency kRansTotal, which keeps the state and is caught by the final state check).
void buildFastTable(const std::array<uint16_t, kTokenCount>& freq, FastTable& t);

// rANS-encodes symbols (decode order) with per-context frequencies over `lanes` states (4 for
// coder 3, kSimdStates for coder 4); symbol i uses state lane[i]. Returns the final states of
// lanes 0..stored-1 (state 0 first, each as high then low 16-bit word; lanes from `stored` on
// must be unused) then the renormalisation words, each 16-bit word little-endian.
struct LaneSymbol {
    uint16_t ctx;
    uint8_t token;
    uint8_t lane;
};
std::vector<uint8_t> ransEncodeLanes(const std::vector<LaneSymbol>& symbols,
                                     const std::vector<std::array<uint16_t, kTokenCount>>& freqs,
                                     const std::vector<uint16_t>& ctxToTable, int lanes,
                                     int stored);

// Encoder IO: records the tokens of a run (z is the input) and their extra bits.
struct FastEncodeIO {
    static constexpr bool kEncode = true;
    std::vector<LaneSymbol> symbols;
    BitWriter bits;
    int lanes = kFastStates;  // symbol j of a run uses state j mod lanes
    WalkModels models;        // coders 5, 6 (FastRows)
    CtxMap ctxMap(int c, int kind) const { return rawCtxMap(c, kind); }
    // Coder 6's eps run of a component: as run<false> (the decoder's may take a faster path).
    void runEps(int, const uint16_t* ctx, int n, uint8_t* z) { run<false>(ctx, n, z); }
    template <bool kExtra>
    void run(const uint16_t* ctx, int n, uint8_t* z) {
        for (int j = 0; j < n; ++j) {
            if constexpr (kExtra) {
                const TokenSplit s = splitToken(z[j]);
                symbols.push_back({ctx[j], uint8_t(s.token), uint8_t(j % lanes)});
                if (s.bits) bits.put(s.extra, s.bits);
            } else {
                symbols.push_back({ctx[j], z[j], uint8_t(j % lanes)});
            }
        }
    }
};

// Decoder IO: four rANS states over a bounds-checked word stream, extra bits from a separate
// bit stream. Past the end of either stream reads give zeros and the overrun is recorded.
struct FastDecodeIO : WordStream {
    static constexpr bool kEncode = false;
    const FastTable* const* tableOf;  // raw context -> its table
    BitReader bits;
    uint32_t x[kFastStates] = {};
    static constexpr WalkModels models{};  // coder 3

    FastDecodeIO(const FastTable* const* tables, const uint8_t* begin, const uint8_t* streamEnd,
                 BitReader extra)
        : WordStream{begin, streamEnd}, tableOf(tables), bits(extra) {
        for (uint32_t& s : x) {
            s = readWord() << 16;
            s |= readWord();
        }
    }
    // True when the stream was used up exactly and all states returned to their initial value.
    bool finishedCleanly() const { return WordStream::finishedCleanly(x); }
    CtxMap ctxMap(int c, int kind) const { return rawCtxMap(c, kind); }
    // Coder 6's walker needs it too (coder 3 never walks by component): as run<false>.
    void runEps(int, const uint16_t* ctx, int n, uint8_t* z) { run<false>(ctx, n, z); }

    // One symbol with state s; the renormalisation word is read unchecked (the caller made sure
    // that 2 bytes remain).
    static inline int step(uint32_t& s, const FastTable& t, const uint8_t*& p) {
        const uint32_t slot = s & (kRansTotal - 1);
        const int tok = t.sym[slot];
        const uint32_t fc = t.freqCum[tok];
        s = (fc & 0xFFFF) * (s >> kRansPrecision) + slot - (fc >> 16);
        // Branch-free renormalisation (whether a word is read is unpredictable).
        const uint32_t renorm = s < kRansLow ? 1u : 0u;
        uint16_t w;
        std::memcpy(&w, p, 2);  // little-endian hosts only (checked in decoder.cpp)
        s = (s << (renorm << 4)) | (uint32_t(w) & (0u - renorm));
        p += renorm << 1;
        return tok;
    }

    // Scalar code on purpose: GCC's SLP vectoriser packs the four states into a vector here,
    // which serialises them on the shared word pointer.
    template <bool kExtra>
    PLX_PTM_NO_SLP void run(const uint16_t* ctx, int n, uint8_t* z) {
        constexpr int L = kFastStates;
        uint32_t s[L];
        for (int l = 0; l < L; ++l) s[l] = x[l];
        const uint8_t* p = ptr;
        const uint8_t* const streamEnd = end;
        const FastTable* const* const tabs = tableOf;  // locals: z's byte stores cannot alias
        BitReader br = bits;  // locals: the byte stores to z cannot alias them
        int j = 0;
        auto value = [&](int tok) {
            if constexpr (kExtra)
                return uint8_t(kTokens.base[size_t(tok)] + br.take(kTokens.bits[size_t(tok)]));
            else
                return uint8_t(tok);
        };
        // Fast path: L symbols at a time while 2 L bytes (L words) remain. A token has at most
        // 6 extra bits: ensure24 covers four tokens.
        for (; j + L <= n && streamEnd - p >= 2 * L; j += L) {
            int t[L];
#pragma GCC unroll 8
            for (int l = 0; l < L; ++l) t[l] = step(s[l], *tabs[ctx[j + l]], p);
#pragma GCC unroll 8
            for (int l = 0; l < L; ++l) {
                if (kExtra && l % 4 == 0) br.ensure24();
                z[j + l] = value(t[l]);
            }
        }
        ptr = p;
        for (int l = 0; l < L; ++l) x[l] = s[l];
        for (; j < n; ++j) {  // the tail and the stream's end, checked
            uint32_t& st = x[j % kFastStates];
            const FastTable& t = *tableOf[ctx[j]];
            const uint32_t slot = st & (kRansTotal - 1);
            const int tok = t.sym[slot];
            const uint32_t fc = t.freqCum[tok];
            st = (fc & 0xFFFF) * (st >> kRansPrecision) + slot - (fc >> 16);
            if (st < kRansLow) st = (st << 16) | readWord();
            if constexpr (kExtra) br.ensure24();
            z[j] = value(tok);
        }
        bits = br;
    }
};

// |unzigzag(z)| and unzigzag(z), branch-free.
inline int magnitude(int z) { return (z + 1) >> 1; }
inline int unzigzagFast(int z) { return (z >> 1) ^ -(z & 1); }
// activityBucket (ctx_codec.h) by comparisons, so that loops over a row vectorise.
constexpr int bucketOf(int a) {
    return (a >= 2) + (a >= 4) + (a >= 6) + (a >= 9) + (a >= 12) + (a >= 16) + (a >= 21) +
           (a >= 28) + (a >= 38) + (a >= 52) + (a >= 72);
}

// The walker's per-block values (pixels, predictions, residuals, activities, statistics) as
// int16: every stored value lies within +-3500, also in a corrupt level (p11 within -765..1275,
// its half-step residual r3 within +-3400), so the AVX2 passes load sixteen per vector and the
// rows take half the cache of int (with the passes written for int16 lanes, decode 1.08x to
// 1.46x as fast as with int rows, median 1.37x; docs/ptm-results.md).
using Lane = int16_t;

// Per-level working rows of walkLevelFast, planar. Parent rows and statistics are padded by
// one replicated entry at each end: index c * (lw + 2) + bx + 1. Block rows: c * lw + bx.
// Runs: c * n + bx for the n blocks of the run.
struct FastRows {
    std::vector<Lane> pu, pm, pd;                    // lower level rows by - 1, by, by + 1
    std::vector<Lane> m, u0, u1, u2, u3, act0, sel;  // per block of the row
    std::vector<uint8_t> z0, z1, z2, ze;            // run values
    std::vector<Lane> v0, v1, v2, v3;               // pixel values of the full blocks
    std::vector<Lane> errA, errB;
    // A-residuals (value - A prediction) of p00, p10, p01, per component: row c * lw + bx, and
    // a row C of zeros that stands for the component before component 0.
    std::vector<Lane> rA0, rA1, rA2;
    std::vector<uint16_t> ctx;
    std::vector<Lane> mag;          // scratch: magnitudes of a run, padded
    std::vector<uint8_t> magBytes;  // the same as bytes (fullRunContextsAvx2)
    // Statistics of the previous and the current block row: activity (sum of |residual|) and
    // sub-predictor errors.
    std::vector<Lane> prevAct, prevEA, prevEB, curAct, curEA, curEB;
    WalkModels models;  // the group's (coders 5, 6)
    // Coders 5, 6 (models.above): the detail (value - upsample) of p01 and p11 of each full block
    // of the previous block row, the pixels right above this row's p00 and p10 (zero before the
    // second block row and beyond the full blocks).
    std::vector<Lane> detail01, detail11;
    // Coder 6: p11's half-step residual 2 p11 - (planar + u3), per component as rA0..rA2.
    std::vector<Lane> r3;
    int comps = 0, lw = 0;
    // Component c's row of a per-component array (c < 0: the row of zeros).
    Lane* compRow(std::vector<Lane>& v, int c) {
        return v.data() + size_t(c < 0 ? comps : c) * size_t(lw);
    }
    // Coder 6's second component before c, whose residuals it averages with the previous
    // one's: c - 2, or for c < 2 the previous one again (its mean with itself is itself; for
    // c == 0 both are the row of zeros).
    static int secondBefore(int c) { return c >= 2 ? c - 2 : c - 1; }
    FastRows(int C, int levelWidth, const WalkModels& groupModels)
        : models(groupModels), comps(C), lw(levelWidth) {
        const size_t n = size_t(C) * size_t(lw), s = size_t(C) * size_t(lw + 2);
        for (auto* v : {&m, &u0, &u1, &u2, &u3, &act0, &sel, &v0, &v1, &v2, &v3, &errA, &errB})
            v->assign(n, 0);
        if (models.above)
            for (auto* v : {&detail01, &detail11}) v->assign(n, 0);
        for (auto* v : {&z0, &z1, &z2, &ze}) v->assign(n, 0);
        for (auto* v : {&rA0, &rA1, &rA2, &r3}) v->assign(n + size_t(lw), 0);
        ctx.assign(n, 0);
        mag.assign(size_t(lw) + 2, 0);
        magBytes.assign(size_t(lw) + 2, 0);
        for (auto* v : {&pu, &pm, &pd, &prevAct, &prevEA, &prevEB, &curAct, &curEA, &curEB})
            v->assign(s, 0);
    }
};

// Deinterleaves component c of a lower-level row into a padded planar row.
template <int C>
void planarRow(const uint8_t* row, int lw, int c, Lane* out) {
    for (int bx = 0; bx < lw; ++bx) out[bx + 1] = row[size_t(bx) * C + size_t(c)];
    out[0] = out[1];
    out[lw + 1] = out[lw];
}

#if defined(__AVX2__)
namespace avx2 {
// Sixteen entries of a walker row.
inline __m256i load16(const Lane* p) {
    return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}
inline void store16(Lane* p, __m256i v) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v);
}
// x / 2^k truncated toward zero (C++ division), int16 lanes.
template <int kShift>
inline __m256i divPow2(__m256i x) {
    const __m256i bias =
        _mm256_and_si256(_mm256_srai_epi16(x, 15), _mm256_set1_epi16(int16_t((1 << kShift) - 1)));
    return _mm256_srai_epi16(_mm256_add_epi16(x, bias), kShift);
}
// x / 3 truncated toward zero for every int16 x: high half of x * 0x5556, plus 1 if x < 0.
inline __m256i div3(__m256i x) {
    return _mm256_sub_epi16(_mm256_mulhi_epi16(x, _mm256_set1_epi16(0x5556)),
                            _mm256_srai_epi16(x, 15));
}
inline __m256i clamp255(__m256i x) {
    return _mm256_min_epi16(_mm256_max_epi16(x, _mm256_setzero_si256()), _mm256_set1_epi16(255));
}
// Sixteen bytes as int16 lanes.
inline __m256i widen16(const uint8_t* p) {
    return _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}
// magnitude() of sixteen run values, as bytes: (z + 1) >> 1 is the rounding average with 0.
inline __m128i magnitudes8(const uint8_t* z) {
    return _mm_avg_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(z)), _mm_setzero_si128());
}
// The same as int16 lanes.
inline __m256i magnitudes16(const uint8_t* z) {
    return _mm256_cvtepu8_epi16(magnitudes8(z));
}
// A context map over q < n <= 16 as a byte lookup: ctx(q) = base + lut[q]. False when an
// offset map(q) - map(0) does not fit a byte (then the caller takes its scalar loop).
struct CtxLut {
    __m256i lut, base;
    alignas(16) uint8_t offsets[16] = {};
    int first = 0;  // map(0)
    bool make(CtxMap map, int n) {
        for (int q = 0; q < n; ++q) {
            const int off = map(q) - map(0);
            if (off < 0 || off > 255) return false;
            offsets[q] = uint8_t(off);
        }
        lut =
            _mm256_broadcastsi128_si256(_mm_load_si128(reinterpret_cast<const __m128i*>(offsets)));
        first = map(0);
        base = _mm256_set1_epi16(int16_t(first));
        return true;
    }
    // The contexts of sixteen int16 q in 0..15.
    __m256i operator()(__m256i q) const {
        return _mm256_add_epi16(
            base, _mm256_and_si256(_mm256_shuffle_epi8(lut, q), _mm256_set1_epi16(0xFF)));
    }
};
}  // namespace avx2
#endif

#if defined(__AVX2__)
// The int16-lane operations of the walker's vector passes for one vector width, so that one
// template body (prepareRowVec, codeFullRowVec, crossEpsContextsVec, finishFullRowVec) serves
// AVX2 (Lanes16) and AVX-512 (Lanes32, 32 blocks per step). M is a lane mask: a vector of
// 0 / -1 lanes for AVX2, a mask register for AVX-512.
struct Lanes16 {
    using V = __m256i;
    using M = __m256i;
    static constexpr int kLanes = 16;
    static V load(const Lane* p) { return avx2::load16(p); }
    static void store(Lane* p, V v) { avx2::store16(p, v); }
    static V widen(const uint8_t* p) { return avx2::widen16(p); }  // kLanes bytes
    // Lanes within 0..255 to kLanes bytes.
    static void storeBytes(uint8_t* p, V v) {
        const __m256i bytes = _mm256_permute4x64_epi64(_mm256_packus_epi16(v, v), 0xD8);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(p), _mm256_castsi256_si128(bytes));
    }
    static V set(int x) { return _mm256_set1_epi16(int16_t(x)); }
    static V add(V a, V b) { return _mm256_add_epi16(a, b); }
    static V sub(V a, V b) { return _mm256_sub_epi16(a, b); }
    static V mullo(V a, V b) { return _mm256_mullo_epi16(a, b); }
    static V bitAnd(V a, V b) { return _mm256_and_si256(a, b); }
    static V bitXor(V a, V b) { return _mm256_xor_si256(a, b); }
    static V abs(V a) { return _mm256_abs_epi16(a); }
    template <int k> static V shl(V a) { return _mm256_slli_epi16(a, k); }
    template <int k> static V shr(V a) { return _mm256_srli_epi16(a, k); }  // logical
    template <int k> static V sar(V a) { return _mm256_srai_epi16(a, k); }  // arithmetic
    template <int k> static V divPow2(V a) { return avx2::divPow2<k>(a); }
    static V div3(V a) { return avx2::div3(a); }
    static V clamp255(V a) { return avx2::clamp255(a); }
    static V min(V a, V b) { return _mm256_min_epi16(a, b); }
    static V max(V a, V b) { return _mm256_max_epi16(a, b); }
    static V magnitudes(const uint8_t* z) { return avx2::magnitudes16(z); }  // kLanes bytes
    static M greater(V a, V b) { return _mm256_cmpgt_epi16(a, b); }
    static M either(M a, M b) { return _mm256_or_si256(a, b); }
    static M none() { return _mm256_setzero_si256(); }
    static bool any(M m) { return _mm256_movemask_epi8(m) != 0; }
    static V select(M m, V a, V b) { return _mm256_blendv_epi8(a, b, m); }  // m ? b : a
    static V keep(M m, V a) { return _mm256_and_si256(m, a); }             // m ? a : 0
    static V contexts(const avx2::CtxLut& map, V q) { return map(q); }   // q in 0..15
};
#endif

#if PLX_PTM_AVX512
struct Lanes32 {
    using V = __m512i;
    using M = __mmask32;
    static constexpr int kLanes = 32;
    static V load(const Lane* p) { return _mm512_loadu_si512(p); }
    static void store(Lane* p, V v) { _mm512_storeu_si512(p, v); }
    static V widen(const uint8_t* p) {
        return _mm512_cvtepu8_epi16(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)));
    }
    static void storeBytes(uint8_t* p, V v) {
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), _mm512_cvtepi16_epi8(v));
    }
    static V set(int x) { return _mm512_set1_epi16(int16_t(x)); }
    static V add(V a, V b) { return _mm512_add_epi16(a, b); }
    static V sub(V a, V b) { return _mm512_sub_epi16(a, b); }
    static V mullo(V a, V b) { return _mm512_mullo_epi16(a, b); }
    static V bitAnd(V a, V b) { return _mm512_and_si512(a, b); }
    static V bitXor(V a, V b) { return _mm512_xor_si512(a, b); }
    static V abs(V a) { return _mm512_abs_epi16(a); }
    template <int k> static V shl(V a) { return _mm512_slli_epi16(a, k); }
    template <int k> static V shr(V a) { return _mm512_srli_epi16(a, k); }
    template <int k> static V sar(V a) { return _mm512_srai_epi16(a, k); }
    // As avx2::divPow2, div3 and clamp255.
    template <int k> static V divPow2(V a) {
        return sar<k>(add(a, bitAnd(sar<15>(a), set((1 << k) - 1))));
    }
    static V div3(V a) { return sub(_mm512_mulhi_epi16(a, set(0x5556)), sar<15>(a)); }
    static V clamp255(V a) {
        return _mm512_min_epi16(_mm512_max_epi16(a, _mm512_setzero_si512()), set(255));
    }
    static V min(V a, V b) { return _mm512_min_epi16(a, b); }
    static V max(V a, V b) { return _mm512_max_epi16(a, b); }
    static V magnitudes(const uint8_t* z) {
        const __m256i bytes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(z));
        return _mm512_cvtepu8_epi16(_mm256_avg_epu8(bytes, _mm256_setzero_si256()));
    }
    static M greater(V a, V b) { return _mm512_cmpgt_epi16_mask(a, b); }
    static M either(M a, M b) { return a | b; }
    static M none() { return 0; }
    static bool any(M m) { return m != 0; }
    static V select(M m, V a, V b) { return _mm512_mask_blend_epi16(m, a, b); }
    static V keep(M m, V a) { return _mm512_maskz_mov_epi16(m, a); }
    static V contexts(const avx2::CtxLut& map, V q) {
        const __m512i lut =
            _mm512_broadcast_i32x4(_mm_load_si128(reinterpret_cast<const __m128i*>(map.offsets)));
        return add(set(map.first), bitAnd(_mm512_shuffle_epi8(lut, q), set(0xFF)));
    }
};
using WidestLanes = Lanes32;
#elif defined(__AVX2__)
using WidestLanes = Lanes16;
#else
using WidestLanes = void;  // no vector passes: the scalar loops do every block
#endif

#if defined(__AVX2__)
// prepareRow for blocks 0..kLanes k - 1, W::kLanes blocks per step in int16 lanes (upsamples of
// bytes stay below 2^12; the shapes' w * detail / 8 within +-10400 also in a corrupt level,
// whose p11 may leave 0..255). Bit-exact with the scalar loop, which does the rest. Returns the
// first block not done.
template <class W, bool kShapeAbove>
int prepareRowVec(FastRows& R, int lw, int c, bool firstRow) {
    using V = typename W::V;
    const size_t sw = size_t(lw + 2), o = size_t(c) * sw + 1, b = size_t(c) * size_t(lw);
    const Lane* pu = R.pu.data() + o;
    const Lane* pm = R.pm.data() + o;
    const Lane* pd = R.pd.data() + o;
    const Lane* act = R.prevAct.data() + o;
    const Lane* ea = R.prevEA.data() + o;
    const Lane* eb = R.prevEB.data() + o;
    const Lane* d01 = kShapeAbove ? R.detail01.data() + b : nullptr;
    const Lane* d11 = kShapeAbove ? R.detail11.data() + b : nullptr;
    const V eight = W::set(8), w = W::set(R.models.shapeEighths);
    const V interOne = W::set(c > 0 && !firstRow ? 1 : 0);
    // upsample(m, side, vert, diag) = (9 m + 3 (side + vert) + diag + 8) >> 4, all terms >= 0.
    auto up = [](V m9, V side, V vert, V diag) {
        const V sv = W::add(side, vert);
        return W::template shr<4>(W::add(W::add(m9, W::add(sv, W::template shl<1>(sv))), diag));
    };
    // 2 x + left + right of a padded statistics row.
    auto spread = [](const Lane* v, V mid) {
        return W::add(W::template shl<1>(mid), W::add(W::load(v - 1), W::load(v + 1)));
    };
    int bx = 0;
    for (; bx + W::kLanes <= lw; bx += W::kLanes) {
        const V mm = W::load(pm + bx), l = W::load(pm + bx - 1), r = W::load(pm + bx + 1);
        const V u = W::load(pu + bx), d = W::load(pd + bx);
        const V m9 = W::add(W::add(W::template shl<3>(mm), mm), eight);
        V u0 = up(m9, l, u, W::load(pu + bx - 1)), u1 = up(m9, r, u, W::load(pu + bx + 1));
        if constexpr (kShapeAbove) {  // + w * detail / 8, truncated
            u0 = W::add(u0, W::template divPow2<3>(W::mullo(w, W::load(d01 + bx))));
            u1 = W::add(u1, W::template divPow2<3>(W::mullo(w, W::load(d11 + bx))));
        }
        W::store(R.m.data() + b + size_t(bx), mm);
        W::store(R.u0.data() + b + size_t(bx), u0);
        W::store(R.u1.data() + b + size_t(bx), u1);
        W::store(R.u2.data() + b + size_t(bx), up(m9, l, d, W::load(pd + bx - 1)));
        W::store(R.u3.data() + b + size_t(bx), up(m9, r, d, W::load(pd + bx + 1)));
        const V grad = W::add(W::abs(W::sub(l, r)), W::abs(W::sub(u, d)));
        V act0;
        if (firstRow) {
            act0 = W::template shl<2>(grad);
        } else {  // ((3 a + left + right) >> 1) + grad
            const V a = W::load(act + bx);
            act0 = W::add(W::template shr<1>(W::add(spread(act + bx, a), a)), grad);
        }
        W::store(R.act0.data() + b + size_t(bx), act0);
        const V errA = spread(ea + bx, W::load(ea + bx));
        const V errB = spread(eb + bx, W::load(eb + bx));
        W::store(R.sel.data() + b + size_t(bx), W::keep(W::greater(errA, errB), interOne));
    }
    return bx;
}
#endif

// Pass 0 of a block row: parents, upsamples, activity and sub-predictor choice of every block
// of component c, from the lower level and the previous block row only (no clamping: the
// padded rows replicate the ends).
//
// kShapeAbove (coders 5 and 6, blocks two pixels tall): the shapes of p00 and p10 corrected by
// w / 8 of the detail (value - upsample) of the pixel right above each, p01 and p11 of the block
// above (w = R.models.shapeEighths: 4, half the detail, in coder 5; chosen per group in coder 6);
// C++ division, truncated toward zero. The block-sum predictor spreads the block's sum by these
// shapes, so the pixels above steer how it splits between the block's upper and lower rows
// (0.924x -> 0.919x optipng -o2 on the 69 Sponza textures with coder 4's other models; the whole
// detail gives 0.943x). The details are zero on the first block row and from `full` on (odd
// widths: finishFullRow keeps only the full blocks'), which keeps those blocks' bilinear
// shapes.
// With AVX2, the first blocks by prepareRowVec in the widest lanes the build has (W: Lanes32
// with AVX-512, else Lanes16); kFast = false runs the scalar loop for every block (the
// reference that fast_paths_test compares the vector paths with).
template <bool kShapeAbove, bool kFast = true, class W = WidestLanes>
void prepareRow(FastRows& R, int lw, int c, bool firstRow) {
    int start = 0;
#if defined(__AVX2__)
    if constexpr (kFast) start = prepareRowVec<W, kShapeAbove>(R, lw, c, firstRow);
#endif
    const size_t sw = size_t(lw + 2), o = size_t(c) * sw + 1, b = size_t(c) * size_t(lw);
    const Lane* __restrict pu = R.pu.data() + o;
    const Lane* __restrict pm = R.pm.data() + o;
    const Lane* __restrict pd = R.pd.data() + o;
    const Lane* __restrict act = R.prevAct.data() + o;
    const Lane* __restrict ea = R.prevEA.data() + o;
    const Lane* __restrict eb = R.prevEB.data() + o;
    Lane* __restrict m = R.m.data() + b;
    Lane* __restrict u0 = R.u0.data() + b;
    Lane* __restrict u1 = R.u1.data() + b;
    Lane* __restrict u2 = R.u2.data() + b;
    Lane* __restrict u3 = R.u3.data() + b;
    Lane* __restrict act0 = R.act0.data() + b;
    Lane* __restrict sel = R.sel.data() + b;
    const Lane* __restrict d01 = kShapeAbove ? R.detail01.data() + b : nullptr;
    const Lane* __restrict d11 = kShapeAbove ? R.detail11.data() + b : nullptr;
    const int inter = c > 0 && !firstRow ? 1 : 0;
    const int upWeight = firstRow ? 0 : 1, gradWeight = firstRow ? 4 : 1;
    const int w = R.models.shapeEighths;
    PLX_PTM_IVDEP
    for (int bx = start; bx < lw; ++bx) {
        const int mm = pm[bx], l = pm[bx - 1], r = pm[bx + 1], up = pu[bx], dn = pd[bx];
        m[bx] = mm;
        u0[bx] = upsample(mm, l, up, pu[bx - 1]);
        u1[bx] = upsample(mm, r, up, pu[bx + 1]);
        if constexpr (kShapeAbove) {
            u0[bx] += w * d01[bx] / 8;  // coder 5: w = 4, d / 2
            u1[bx] += w * d11[bx] / 8;
        }
        u2[bx] = upsample(mm, l, dn, pd[bx - 1]);
        u3[bx] = upsample(mm, r, dn, pd[bx + 1]);
        const int grad = std::abs(l - r) + std::abs(up - dn);
        act0[bx] = upWeight * ((3 * act[bx] + act[bx - 1] + act[bx + 1]) >> 1) + gradWeight * grad;
        const int errA = 2 * ea[bx] + ea[bx - 1] + ea[bx + 1];
        const int errB = 2 * eb[bx] + eb[bx - 1] + eb[bx + 1];
        sel[bx] = inter & (errB < errA ? 1 : 0);
    }
}

#if defined(__AVX2__)
// codeFullRow for blocks 0..kLanes k - 1 of component c, W::kLanes blocks per step in int16
// lanes (every intermediate of the block-sum predictor lies in -8160..5102, also with coder 5's
// shapes u0, u1 in -127..382; in a corrupt level, whose p11 may leave 0..255 and so move the
// next row's shapes to -510..893, they stay within +-15000). Bit-exact with the scalar loop,
// which does the rest. Returns the first block not done. kEncode, kCross: as codeFullRow's.
template <class W, bool kEncode, bool kCross>
int codeFullRowVec(FastRows& R, int lw, int full, int c) {
    using V = typename W::V;
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* m = R.m.data() + pi;
    const Lane* u0 = R.u0.data() + pi;
    const Lane* u1 = R.u1.data() + pi;
    const Lane* u2 = R.u2.data() + pi;
    const Lane* u3 = R.u3.data() + pi;
    const Lane* sel = R.sel.data() + pi;
    Lane* v0 = R.v0.data() + ri;
    Lane* v1 = R.v1.data() + ri;
    Lane* v2 = R.v2.data() + ri;
    uint8_t* z0 = R.z0.data() + ri;
    uint8_t* z1 = R.z1.data() + ri;
    uint8_t* z2 = R.z2.data() + ri;
    Lane* errA = R.errA.data() + ri;
    Lane* errB = R.errB.data() + ri;
    // Rows of this component (written), the previous one and the one before that (read).
    Lane* const own[3] = {R.compRow(R.rA0, c), R.compRow(R.rA1, c), R.compRow(R.rA2, c)};
    const Lane* const prev[3] = {R.compRow(R.rA0, c - 1), R.compRow(R.rA1, c - 1),
                                 R.compRow(R.rA2, c - 1)};
    const int before = kCross ? FastRows::secondBefore(c) : c - 1;  // as codeFullRow's
    const Lane* const prev2[3] = {R.compRow(R.rA0, before), R.compRow(R.rA1, before),
                                  R.compRow(R.rA2, before)};
    const bool inter = c > 0;
    const V zero = W::set(0), one = W::set(1), mask255 = W::set(255);
    int bx = 0;
    for (; bx + W::kLanes <= full; bx += W::kLanes) {
        const V mm = W::load(m + bx), w0 = W::load(u0 + bx), w1 = W::load(u1 + bx);
        const V w2 = W::load(u2 + bx), w3 = W::load(u3 + bx);
        const auto pickB = W::greater(W::load(sel + bx), zero);
        const V target = W::add(W::template shl<4>(mm), W::set(6));
        V eA = zero, eB = zero;
        // One stored pixel (codeFullRow's `one`): prediction pA from the block-sum predictor's
        // correction corr, B from the previous component's A-residual, value from the run value.
        auto pixel = [&](V u, V corr, Lane* rOwn, const Lane* rPrev, const Lane* rBefore,
                         uint8_t* z, Lane* v) {
            const V pA = W::clamp255(W::add(u, corr));
            V pB = pA;
            if (inter) {
                V r = W::load(rPrev + bx);  // |r| <= 255
                if constexpr (kCross) r = W::template divPow2<1>(W::add(r, W::load(rBefore + bx)));
                pB = W::clamp255(W::add(pA, r));
            }
            const V pred = W::select(pickB, pA, pB);
            V val;
            if constexpr (kEncode) {  // z = zigzag(int8_t(v - pred))
                val = W::load(v + bx);
                const V d = W::template sar<8>(W::template shl<8>(W::sub(val, pred)));
                W::storeBytes(z + bx, W::bitXor(W::template shl<1>(d), W::template sar<15>(d)));
            } else {  // v = (pred + unzigzag(z)) & 255
                const V zz = W::widen(z + bx);
                const V unz = W::bitXor(W::template shr<1>(zz), W::sub(zero, W::bitAnd(zz, one)));
                val = W::bitAnd(W::add(pred, unz), mask255);
                W::store(v + bx, val);
            }
            W::store(rOwn + bx, W::sub(val, pA));
            eA = W::add(eA, W::abs(W::sub(val, pA)));
            eB = W::add(eB, W::abs(W::sub(val, pB)));
            return val;
        };
        // predictBlockPixel(4, m, known, sumU, rem, u): corr = (16 m + 6 - 4 known - 4 sumU)
        // / (4 rem), truncated.
        auto times4 = [](V x) { return W::template shl<2>(x); };
        const V s23 = W::add(w2, w3), s123 = W::add(w1, s23);
        const V a = pixel(w0, W::template divPow2<4>(W::sub(target, times4(W::add(w0, s123)))),
                          own[0], prev[0], prev2[0], z0, v0);
        const V b =
            pixel(w1, W::div3(W::template divPow2<2>(W::sub(target, times4(W::add(a, s123))))),
                  own[1], prev[1], prev2[1], z1, v1);
        pixel(w2, W::template divPow2<3>(W::sub(target, times4(W::add(W::add(a, b), s23)))),
              own[2], prev[2], prev2[2], z2, v2);
        W::store(errA + bx, eA);
        W::store(errB + bx, eB);
    }
    return bx;
}
#endif

// Prediction and reconstruction of the three stored pixels of every full block of a row, for
// component c. Encode: values v0..v2 to run values z0..z2; decode: the reverse. Sub-predictor A
// is the block-sum predictor (codec.h); B (components >= 1) is clamp(A + r, 0, 255) with r the
// previous component's A-residual at the same pixel; `sel` (pass 0) picks B. No dependency
// between blocks: with AVX2, the first blocks by codeFullRowVec in the widest lanes the build
// has (W, as prepareRow's); kFast = false runs the scalar loop for every block (the reference
// of fast_paths_test).
// kCross (coder 6): for components >= 2, r is the mean (truncated) of the A-residuals of the two
// components before: each carries the rounding noise of its own JPEG decode, which the mean
// halves (0.9051x -> 0.9015x optipng -o2 over the 69 Sponza textures; rounding the mean half up
// instead gives 0.9031x, toward minus infinity 0.9018x).
template <bool kEncode, bool kCross, bool kFast = true, class W = WidestLanes>
void codeFullRow(FastRows& R, int lw, int full, int c) {
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* __restrict m = R.m.data() + pi;
    const Lane* __restrict u0 = R.u0.data() + pi;
    const Lane* __restrict u1 = R.u1.data() + pi;
    const Lane* __restrict u2 = R.u2.data() + pi;
    const Lane* __restrict u3 = R.u3.data() + pi;
    const Lane* __restrict sel = R.sel.data() + pi;
    Lane* __restrict v0 = R.v0.data() + ri;
    Lane* __restrict v1 = R.v1.data() + ri;
    Lane* __restrict v2 = R.v2.data() + ri;
    uint8_t* __restrict z0 = R.z0.data() + ri;
    uint8_t* __restrict z1 = R.z1.data() + ri;
    uint8_t* __restrict z2 = R.z2.data() + ri;
    Lane* __restrict errA = R.errA.data() + ri;
    Lane* __restrict errB = R.errB.data() + ri;
    Lane* __restrict rA0 = R.compRow(R.rA0, c);  // this component's, written
    Lane* __restrict rA1 = R.compRow(R.rA1, c);
    Lane* __restrict rA2 = R.compRow(R.rA2, c);
    const Lane* __restrict pr0 = R.compRow(R.rA0, c - 1);  // the previous component's
    const Lane* __restrict pr1 = R.compRow(R.rA1, c - 1);
    const Lane* __restrict pr2 = R.compRow(R.rA2, c - 1);
    // Coder 6: the one before that (FastRows::secondBefore).
    const int before = kCross ? FastRows::secondBefore(c) : c - 1;
    const Lane* __restrict pq0 = R.compRow(R.rA0, before);
    const Lane* __restrict pq1 = R.compRow(R.rA1, before);
    const Lane* __restrict pq2 = R.compRow(R.rA2, before);
    const int inter = c > 0 ? 1 : 0;
    // One stored pixel: prediction from A (and B, from the earlier components' A-residuals p and
    // q), value <-> run value, this component's A-residual kept for the next ones.
    auto one = [&](int pA, int p, int q, Lane& rA, Lane& v, uint8_t& z, int s, int& eA, int& eB) {
        const int r = kCross ? (p + q) / 2 : p;
        const int pB = inter ? std::clamp(pA + r, 0, 255) : pA;
        const int pred = s ? pB : pA;
        if constexpr (kEncode)
            z = uint8_t(zigzag(int(int8_t(uint8_t(v - pred)))));
        else
            v = (pred + unzigzagFast(z)) & 255;
        rA = v - pA;
        eA += std::abs(v - pA);
        eB += std::abs(v - pB);
    };
    int start = 0;
#if defined(__AVX2__)
    if constexpr (kFast) start = codeFullRowVec<W, kEncode, kCross>(R, lw, full, c);
#endif
    PLX_PTM_IVDEP
    for (int bx = start; bx < full; ++bx) {
        const int mm = m[bx], s = sel[bx];
        int eA = 0, eB = 0;
        one(predictBlockPixel(4, mm, 0, u0[bx] + u1[bx] + u2[bx] + u3[bx], 4, u0[bx]), pr0[bx],
            pq0[bx], rA0[bx], v0[bx], z0[bx], s, eA, eB);
        one(predictBlockPixel(4, mm, v0[bx], u1[bx] + u2[bx] + u3[bx], 3, u1[bx]), pr1[bx], pq1[bx],
            rA1[bx], v1[bx], z1[bx], s, eA, eB);
        one(predictBlockPixel(4, mm, v0[bx] + v1[bx], u2[bx] + u3[bx], 2, u2[bx]), pr2[bx], pq2[bx],
            rA2[bx], v2[bx], z2[bx], s, eA, eB);
        errA[bx] = eA;
        errB[bx] = eB;
    }
}

#if defined(__AVX2__)
// The rows of component c that the vector passes of fullRunContexts read and write; pad holds
// the previous run's magnitudes as bytes (kinds 1, 2: p00's run for kind 1, p10's for kind 2),
// ends replicated: e[bx] at pad[bx + 1].
struct RunContextRows {
    const Lane* act0;
    const uint8_t *z0, *z1, *z2;
    uint16_t* ctx;
    const uint8_t* pad;
};
template <int kKind>
RunContextRows runContextRows(FastRows& R, int lw, int full, int c) {
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const RunContextRows rows{R.act0.data() + pi, R.z0.data() + ri, R.z1.data() + ri,
                              R.z2.data() + ri, R.ctx.data() + ri, R.magBytes.data()};
    if constexpr (kKind > 0) {
        uint8_t* pad = R.magBytes.data();
        const uint8_t* zp = kKind == 1 ? rows.z0 : rows.z1;
        for (int i = 0; i + 16 <= full; i += 16)
            _mm_storeu_si128(reinterpret_cast<__m128i*>(pad + 1 + i), avx2::magnitudes8(zp + i));
        for (int i = full & ~15; i < full; ++i) pad[i + 1] = uint8_t(magnitude(zp[i]));
        pad[0] = pad[1];
        pad[full + 1] = pad[full];
    }
    return rows;
}

// The activity of blocks bx..bx+W::kLanes-1 of a run of kind kKind, before bucketOf (every
// intermediate below 2^12: act0 <= 4 * 510, magnitudes <= 128, also in a corrupt level), as
// fullRunContexts' scalar loop: act0, the earlier runs' magnitudes of the block and, kinds 1
// and 2, those of the previous run's neighbours (rows.pad); with `cross`, the previous
// component's magnitudes.
template <class W, int kKind>
typename W::V runActivity(const RunContextRows& rows, int full, int bx, bool cross) {
    using V = typename W::V;
    const auto [act0, z0, z1, z2, ctx, pad] = rows;
    V a = W::load(act0 + bx);
    if constexpr (kKind == 1) {  // (a + 3 e + e left + e right) >> 1
        const V e = W::widen(pad + bx + 1);
        a = W::add(a, W::add(e, W::template shl<1>(e)));
        a = W::add(a, W::add(W::widen(pad + bx), W::widen(pad + bx + 2)));
        a = W::template shr<1>(a);
    } else if constexpr (kKind == 2) {  // (a + 3 |z0| + 2 e + e left) >> 1
        const V m0 = W::magnitudes(z0 + bx);
        a = W::add(a, W::add(m0, W::template shl<1>(m0)));
        a = W::add(a, W::add(W::template shl<1>(W::widen(pad + bx + 1)), W::widen(pad + bx)));
        a = W::template shr<1>(a);
    }
    if (cross) {  // the previous component's magnitudes, as the scalar loop's `extra`
        const V y0 = W::magnitudes(z0 + bx - full), y1 = W::magnitudes(z1 + bx - full);
        const V y2 = W::magnitudes(z2 + bx - full);
        const V same = kKind == 0 ? y0 : kKind == 1 ? y1 : y2;
        const V block = W::add(W::add(y0, y1), y2);
        const V sum = W::add(W::template shl<2>(same), W::template shl<1>(block));
        a = W::add(a, W::template shr<2>(sum));
    }
    return a;
}

#endif

#if defined(__AVX2__)
// fullRunContexts for rows of at least 16 blocks: activities sixteen blocks at a time in int16
// lanes (every intermediate is below 2^12: act0 <= 4 * 510, magnitudes <= 128, also in a corrupt
// level), bucketed 32 at a time in bytes; near the row's end the groups of 16 overlap. Bit-exact
// with the scalar loop. Returns false, having done nothing, when a table offset of `map` does not
// fit a byte.
template <int kKind>
bool fullRunContextsAvx2(FastRows& R, int lw, int full, int c, CtxMap map, bool cross) {
    using namespace avx2;
    CtxLut ctxOf;
    if (!ctxOf.make(map, kActivityBuckets)) return false;
    const RunContextRows rows = runContextRows<kKind>(R, lw, full, c);
    uint16_t* ctx = rows.ctx;
    auto activity = [&](int bx) { return runActivity<Lanes16, kKind>(rows, full, bx, cross); };
    // bucketOf on 32 blocks at once, in bytes: the activities saturated to 127 (the last
    // threshold is 72), then the number of thresholds reached (each comparison gives -1).
    constexpr std::array<int8_t, 11> kBelow = {1, 3, 5, 8, 11, 15, 20, 27, 37, 51, 71};
    const __m256i cap = _mm256_set1_epi8(127);
    for (int step = 0; step < full; step += 32) {
        // Two groups of 16 blocks; near the row's end they overlap (the same values twice).
        const int b0 = std::min(step, full - 16), b1 = std::min(step + 16, full - 16);
        const __m256i a = _mm256_min_epu8(
            _mm256_permute4x64_epi64(_mm256_packus_epi16(activity(b0), activity(b1)), 0xD8), cap);
        __m256i q = _mm256_setzero_si256();
        for (const int8_t t : kBelow)
            q = _mm256_sub_epi8(q, _mm256_cmpgt_epi8(a, _mm256_set1_epi8(t)));
        const __m256i off = _mm256_shuffle_epi8(ctxOf.lut, q);  // map(q) - map(0), bytes
        auto store = [&](int bx, __m128i bytes) {
            _mm256_storeu_si256(reinterpret_cast<__m256i*>(ctx + bx),
                                _mm256_add_epi16(ctxOf.base, _mm256_cvtepu8_epi16(bytes)));
        };
        store(b0, _mm256_castsi256_si128(off));
        store(b1, _mm256_extracti128_si256(off, 1));
    }
    return true;
}
#endif

#if PLX_PTM_AVX512 && defined(__AVX512VBMI__)
// Per activity 0..127 its bucket (bucketOf), for vpermb: activities from 72 on share the last.
struct BucketBytes {
    alignas(64) uint8_t of[128]{};
    constexpr BucketBytes() {
        for (int a = 0; a < 128; ++a) of[a] = uint8_t(bucketOf(a));
    }
};
inline constexpr BucketBytes kBucketBytes{};

// fullRunContexts for rows of at least 32 blocks with AVX-512 VBMI: activities 32 blocks at a
// time (runActivity in Lanes32), saturated to 127 and turned into the context's offset by one
// vpermi2b over a 128-byte table of map(bucketOf(a)) - map(0); near the row's end the last
// step overlaps the one before. Bit-exact with the scalar loop. Returns false, having done
// nothing, when a table offset of `map` does not fit a byte.
template <int kKind>
bool fullRunContextsAvx512(FastRows& R, int lw, int full, int c, CtxMap map, bool cross) {
    avx2::CtxLut ctxOf;
    if (!ctxOf.make(map, kActivityBuckets)) return false;
    const RunContextRows rows = runContextRows<kKind>(R, lw, full, c);
    // The offset of every activity 0..127: the bucket's offset, looked up by the bucket.
    const __m512i offsets =
        _mm512_broadcast_i32x4(_mm_load_si128(reinterpret_cast<const __m128i*>(ctxOf.offsets)));
    auto table = [&](int half) {
        return _mm512_permutexvar_epi8(_mm512_load_si512(kBucketBytes.of + 64 * half), offsets);
    };
    const __m512i lo = table(0), hi = table(1);
    const __m512i first = _mm512_set1_epi16(int16_t(ctxOf.first));
    for (int step = 0; step < full; step += Lanes32::kLanes) {
        const int bx = std::min(step, full - Lanes32::kLanes);
        const __m512i a = runActivity<Lanes32, kKind>(rows, full, bx, cross);
        const __m256i q = _mm512_cvtepi16_epi8(_mm512_min_epi16(a, _mm512_set1_epi16(127)));
        const __m512i off = _mm512_permutex2var_epi8(lo, _mm512_castsi256_si512(q), hi);
        const __m512i bytes = _mm512_cvtepu8_epi16(_mm512_castsi512_si256(off));
        _mm512_storeu_si512(rows.ctx + bx, _mm512_add_epi16(first, bytes));
    }
    return true;
}
#endif

// Contexts of a run of the full blocks of a row, component c (kind 0..2 the stored position,
// from the row's activity act0 and the magnitudes of the runs already decoded).
// With AVX-512 VBMI (W = Lanes32), rows of at least 32 blocks by fullRunContextsAvx512; with
// AVX2, rows of at least 16 by fullRunContextsAvx2; kFast = false runs the scalar loop below
// (the reference that fast_paths_test compares the vector paths with).
template <int kKind, bool kFast = true, class W = WidestLanes>
void fullRunContexts(FastRows& R, int lw, int full, int c, CtxMap map) {
#if defined(__AVX2__)
    if constexpr (kFast) {
        const bool cross = R.models.cross && c > 0;
#if PLX_PTM_AVX512 && defined(__AVX512VBMI__)
        if constexpr (W::kLanes == 32)
            if (full >= 32 && fullRunContextsAvx512<kKind>(R, lw, full, c, map, cross)) return;
#endif
        if (full >= 16 && fullRunContextsAvx2<kKind>(R, lw, full, c, map, cross)) return;
    }
#endif
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* __restrict act0 = R.act0.data() + pi;
    const uint8_t* __restrict z0 = R.z0.data() + ri;
    const uint8_t* __restrict z1 = R.z1.data() + ri;
    uint16_t* __restrict ctx = R.ctx.data() + ri;
    Lane* __restrict e = R.mag.data() + 1;  // magnitudes of the previous run, ends replicated
    if constexpr (kKind > 0) {
        const uint8_t* __restrict zp = kKind == 1 ? z0 : z1;
PLX_PTM_IVDEP
        for (int bx = 0; bx < full; ++bx) e[bx] = magnitude(zp[bx]);
        e[-1] = e[0];
        e[full] = e[full - 1];
    }
    auto contexts = [&](auto extra) {
        PLX_PTM_IVDEP
        for (int bx = 0; bx < full; ++bx) {
            int a = act0[bx];
            if constexpr (kKind == 1)
                a = (a + 3 * e[bx] + e[bx - 1] + e[bx + 1]) >> 1;
            else if constexpr (kKind == 2)
                a = (a + 3 * magnitude(z0[bx]) + 2 * e[bx] + e[bx - 1]) >> 1;
            ctx[bx] = uint16_t(map(bucketOf(a + extra(bx))));
        }
    };
    if (!R.models.cross || c == 0) return contexts([](int) { return 0; });
    // Coder 6: the previous component's magnitudes in the same block, decoded before this run
    // (component-major rows): the same position weighted 1, each of its three stored pixels
    // 1/2 (0.9075x -> 0.9051x optipng -o2 over the 69 Sponza textures; the same position alone
    // 0.9052x at weight 1, 0.9053x at 1/2).
    const uint8_t* __restrict y0 = z0 - full;  // component c - 1
    const uint8_t* __restrict y1 = z1 - full;
    const uint8_t* __restrict y2 = R.z2.data() + ri - size_t(full);
    const uint8_t* __restrict same = kKind == 0 ? y0 : kKind == 1 ? y1 : y2;
    contexts([=](int bx) {
        const int block = magnitude(y0[bx]) + magnitude(y1[bx]) + magnitude(y2[bx]);
        return (4 * magnitude(same[bx]) + 2 * block) >> 2;
    });
}

#if defined(__AVX2__)
// epsContexts' coder 6 contexts (decode) for blocks 0..kLanes k - 1, W::kLanes blocks per step
// in int16 lanes (every term within +-11000, also in a corrupt level). Bit-exact with the scalar
// loop, which does the rest. Returns the first block not done (0 when `map` does not fit a byte
// lookup).
template <class W>
int crossEpsContextsVec(FastRows& R, int lw, int full, int c, CtxMap map) {
    using V = typename W::V;
    avx2::CtxLut ctxOf;
    if (!ctxOf.make(map, kEpsContexts)) return 0;
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* r3 = R.compRow(R.r3, c - 1);
    const Lane* q3 = R.compRow(R.r3, FastRows::secondBefore(c));
    // c == 0: no inter-component terms (r3 and q3 are then the row of zeros).
    const V inter = W::set(c > 0 ? -1 : 0);
    const V one = W::set(1), zero = W::set(0);
    int bx = 0;
    for (; bx + W::kLanes <= full; bx += W::kLanes) {
        const size_t p = pi + size_t(bx), r = ri + size_t(bx);
        const V v0 = W::load(R.v0.data() + r), v1 = W::load(R.v1.data() + r);
        const V v2 = W::load(R.v2.data() + r), m = W::load(R.m.data() + p);
        const V known = W::sub(W::add(W::add(v0, v1), v2), W::template shl<2>(m));
        const V pr3 = W::load(r3 + bx);
        // sel * ((r3 + q3) >> 1): sel is 0 or 1.
        const V half = W::template sar<1>(W::add(pr3, W::load(q3 + bx)));
        const V corr = W::keep(W::greater(W::load(R.sel.data() + p), zero), W::bitAnd(inter, half));
        V eHalf = W::add(W::template shl<1>(known), W::sub(W::add(v1, v2), v0));
        eHalf = W::add(eHalf, W::add(W::load(R.u3.data() + p), corr));
        // clamp((eHalf + 1) >> 1, -1, 3) + 1, times 3
        const V sHat =
            W::min(W::max(W::template sar<1>(W::add(eHalf, one)), W::set(-1)), W::set(3));
        const V s1 = W::add(sHat, one);
        V act = W::add(W::load(R.act0.data() + p),
                       W::add(W::magnitudes(R.z0.data() + r), W::magnitudes(R.z1.data() + r)));
        act = W::add(act, W::magnitudes(R.z2.data() + r));
        act = W::add(act, W::bitAnd(inter, W::template shl<1>(W::abs(pr3))));
        // + (act >= 6) + (act >= 18)
        V q = W::add(s1, W::template shl<1>(s1));
        q = W::add(q, W::keep(W::greater(act, W::set(5)), one));
        q = W::add(q, W::keep(W::greater(act, W::set(17)), one));
        W::store(reinterpret_cast<Lane*>(R.ctx.data() + r), W::contexts(ctxOf, q));
    }
    return bx;
}
#endif

// eps of the full blocks of a row, component c: contexts from the block sum that the planar
// prediction p11 ~ p10 + p01 - p00 implies (encode: also the eps values).
// With AVX2, the decoder's coder 6 contexts of the first blocks by crossEpsContextsVec in the
// widest lanes the build has (W, as prepareRow's); kFast = false runs the scalar loop for every
// block (the reference of fast_paths_test).
template <bool kEncode, bool kFast = true, class W = WidestLanes>
void epsContexts(FastRows& R, int lw, int full, int c, CtxMap map) {
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* __restrict m = R.m.data() + pi;
    const Lane* __restrict act0 = R.act0.data() + pi;
    const uint8_t* __restrict z0 = R.z0.data() + ri;
    const uint8_t* __restrict z1 = R.z1.data() + ri;
    const uint8_t* __restrict z2 = R.z2.data() + ri;
    const Lane* __restrict v0 = R.v0.data() + ri;
    const Lane* __restrict v1 = R.v1.data() + ri;
    const Lane* __restrict v2 = R.v2.data() + ri;
    const Lane* __restrict v3 = R.v3.data() + ri;
    uint8_t* __restrict ze = R.ze.data() + ri;
    uint16_t* __restrict ctx = R.ctx.data() + ri;
    if (R.models.cross) {
        // Coder 6: as coder 5, and p11's prediction has sub-predictor B as the other pixels
        // (where `sel` picks it): the previous component's p11 residual r3, for components
        // >= 2 the mean of the two before (0.9154x -> 0.9113x optipng -o2 over the 69 Sponza
        // textures; 0.9136x with B everywhere instead of where `sel` picks it). Five eps values
        // around the prediction and three activity levels (0.9015x -> 0.9012x), which also
        // count the previous component's |r3| (0.9077x -> 0.9075x).
        const Lane* __restrict u3 = R.u3.data() + pi;
        const Lane* __restrict sel = R.sel.data() + pi;
        // The two components before (FastRows::secondBefore).
        const Lane* __restrict r3 = R.compRow(R.r3, c - 1);
        const Lane* __restrict q3 = R.compRow(R.r3, FastRows::secondBefore(c));
        const int inter = c > 0 ? 1 : 0;
        int start = 0;
#if defined(__AVX2__)
        if constexpr (!kEncode && kFast) start = crossEpsContextsVec<W>(R, lw, full, c, map);
#endif
        PLX_PTM_IVDEP
        for (int bx = start; bx < full; ++bx) {
            const int known = v0[bx] + v1[bx] + v2[bx] - 4 * m[bx];
            const int corr = inter * sel[bx] * ((r3[bx] + q3[bx]) >> 1);
            const int eHalf = 2 * known + (v1[bx] + v2[bx] - v0[bx]) + u3[bx] + corr;
            const int sHat = std::clamp((eHalf + 1) >> 1, -1, 3);
            const int act = act0[bx] + magnitude(z0[bx]) + magnitude(z1[bx]) + magnitude(z2[bx]) +
                            2 * inter * std::abs(r3[bx]);
            ctx[bx] = uint16_t(map((sHat + 1) * 3 + (act >= 6) + (act >= 18)));
            if constexpr (kEncode) ze[bx] = uint8_t(known + v3[bx]);
        }
        return;
    }
    if (R.models.above) {
        // Coder 5: p11 predicted by the mean of the planar p10 + p01 - p00 and the bilinear
        // upsample u3, in half steps: eHalf = 2 (known sum + p11 - 4 m) is twice the eps that
        // prediction implies (0.924x -> 0.921x optipng -o2 on the Sponza textures).
        const Lane* __restrict u3 = R.u3.data() + pi;
        PLX_PTM_IVDEP
        for (int bx = 0; bx < full; ++bx) {
            const int known = v0[bx] + v1[bx] + v2[bx] - 4 * m[bx];
            const int eHalf = 2 * known + (v1[bx] + v2[bx] - v0[bx]) + u3[bx];
            const int sHat = std::clamp((eHalf + 1) >> 1, -2, 4);
            const int act = act0[bx] + magnitude(z0[bx]) + magnitude(z1[bx]) + magnitude(z2[bx]);
            ctx[bx] = uint16_t(map((sHat + 2) * 2 + (act >= 12 ? 1 : 0)));
            if constexpr (kEncode) ze[bx] = uint8_t(known + v3[bx]);
        }
        return;
    }
PLX_PTM_IVDEP
    for (int bx = 0; bx < full; ++bx) {
        const int sHat = std::clamp(2 * (v1[bx] + v2[bx]) - 4 * m[bx], -2, 4);
        const int act = act0[bx] + magnitude(z0[bx]) + magnitude(z1[bx]) + magnitude(z2[bx]);
        ctx[bx] = uint16_t(map((sHat + 2) * 2 + (act >= 12 ? 1 : 0)));
        if constexpr (kEncode) ze[bx] = uint8_t(v0[bx] + v1[bx] + v2[bx] + v3[bx] - 4 * m[bx]);
    }
}

#if defined(__AVX2__)
// finishFullRow (below) for blocks 0..kLanes k - 1, W::kLanes blocks per step in int16 lanes
// (p11 within -765..1275 and r3 within +-3900 also in a corrupt level). Bit-exact with the
// scalar loops, which do the rest. Returns the first block not done; ORs the range check's
// flags into bad.
template <class W, bool kKeepDetail, bool kCross>
int finishFullRowVec(FastRows& R, int lw, int full, int c, unsigned& bad) {
    using V = typename W::V;
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const size_t si = size_t(c) * size_t(lw + 2) + 1;
    Lane* own3 = R.compRow(R.r3, c);
    const Lane* p3 = R.compRow(R.r3, c - 1);
    const Lane* q3 = R.compRow(R.r3, FastRows::secondBefore(c));
    const V zero = W::set(0);
    auto flags = W::none();
    int bx = 0;
    for (; bx + W::kLanes <= full; bx += W::kLanes) {
        const size_t p = pi + size_t(bx), r = ri + size_t(bx), st = si + size_t(bx);
        const V v0 = W::load(R.v0.data() + r), v1 = W::load(R.v1.data() + r);
        const V v2 = W::load(R.v2.data() + r), u3 = W::load(R.u3.data() + p);
        const V ep = W::widen(R.ze.data() + r);
        const V last = W::sub(W::add(W::template shl<2>(W::load(R.m.data() + p)), ep),
                              W::add(W::add(v0, v1), v2));  // eq. (3)
        flags = W::either(flags, W::greater(ep, W::set(3)));
        flags = W::either(flags, W::greater(zero, last));
        flags = W::either(flags, W::greater(last, W::set(255)));
        W::store(R.v3.data() + r, last);
        if constexpr (kKeepDetail) {
            W::store(R.detail01.data() + p, W::sub(v2, W::load(R.u2.data() + p)));
            W::store(R.detail11.data() + p, W::sub(last, u3));
        }
        W::store(R.curAct.data() + st,
                 W::add(W::add(W::magnitudes(R.z0.data() + r), W::magnitudes(R.z1.data() + r)),
                        W::magnitudes(R.z2.data() + r)));
        V ea = W::load(R.errA.data() + r), eb = W::load(R.errB.data() + r);
        if constexpr (kCross) {
            const V planar = W::sub(W::add(v1, v2), v0);
            const V r3 = W::sub(W::sub(W::template shl<1>(last), planar), u3);
            W::store(own3 + bx, r3);
            if (c > 0) {  // |r3| / 2 and |r3 - B's correction| / 2
                const V corr = W::template sar<1>(W::add(W::load(p3 + bx), W::load(q3 + bx)));
                ea = W::add(ea, W::template shr<1>(W::abs(r3)));
                eb = W::add(eb, W::template shr<1>(W::abs(W::sub(r3, corr))));
            }
        }
        W::store(R.curEA.data() + st, ea);
        W::store(R.curEB.data() + st, eb);
    }
    bad |= unsigned(W::any(flags));
    return bx;
}
#endif

// p11 of the full blocks by eq. (3) and the row's statistics for the next row. Returns a
// non-zero value on an eps >= 4 or a p11 outside 0..255.
// kKeepDetail (coders 5, 6): also keeps the detail of p01 and p11 (value - upsample; u2, u3 are
// never corrected) for the next block row's prepareRow.
// kCross (coder 6): keeps p11's half-step residual for the next components (r3) and adds
// p11's errors under A and B to the block's sub-predictor statistics (components >= 1), so that
// the next row's choice between A and B also weighs p11 (0.9113x -> 0.9077x optipng -o2 over
// the 69 Sponza textures, with the inter-component p11).
// With AVX2, the first blocks by finishFullRowVec in the widest lanes the build has (W, as
// prepareRow's); kFast = false runs the scalar loops for every block (the reference that
// fast_paths_test compares the vector paths with).
template <bool kKeepDetail, bool kCross = false, bool kFast = true, class W = WidestLanes>
unsigned finishFullRow(FastRows& R, int lw, int full, int c) {
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const size_t si = size_t(c) * size_t(lw + 2) + 1;
    const Lane* __restrict m = R.m.data() + pi;
    const uint8_t* __restrict z0 = R.z0.data() + ri;
    const uint8_t* __restrict z1 = R.z1.data() + ri;
    const uint8_t* __restrict z2 = R.z2.data() + ri;
    const uint8_t* __restrict ze = R.ze.data() + ri;
    const Lane* __restrict v0 = R.v0.data() + ri;
    const Lane* __restrict v1 = R.v1.data() + ri;
    const Lane* __restrict v2 = R.v2.data() + ri;
    Lane* __restrict v3 = R.v3.data() + ri;
    const Lane* __restrict errA = R.errA.data() + ri;
    const Lane* __restrict errB = R.errB.data() + ri;
    Lane* __restrict act = R.curAct.data() + si;
    Lane* __restrict ea = R.curEA.data() + si;
    Lane* __restrict eb = R.curEB.data() + si;
    const Lane* __restrict u2 = R.u2.data() + pi;
    const Lane* __restrict u3 = R.u3.data() + pi;
    Lane* __restrict d01 = kKeepDetail ? R.detail01.data() + pi : nullptr;
    Lane* __restrict d11 = kKeepDetail ? R.detail11.data() + pi : nullptr;
    unsigned bad = 0;
    int start = 0;
#if defined(__AVX2__)
    if constexpr (kFast) start = finishFullRowVec<W, kKeepDetail, kCross>(R, lw, full, c, bad);
#endif
    PLX_PTM_IVDEP
    for (int bx = start; bx < full; ++bx) {
        const int ep = ze[bx];
        const int last = 4 * m[bx] + ep - v0[bx] - v1[bx] - v2[bx];  // eq. (3)
        bad |= unsigned(ep >= 4) | unsigned(unsigned(last) > 255u);
        v3[bx] = last;
        if constexpr (kKeepDetail) {
            d01[bx] = v2[bx] - u2[bx];
            d11[bx] = last - u3[bx];
        }
        act[bx] = magnitude(z0[bx]) + magnitude(z1[bx]) + magnitude(z2[bx]);
        ea[bx] = errA[bx];
        eb[bx] = errB[bx];
    }
    if constexpr (kCross) {
        Lane* __restrict r3 = R.compRow(R.r3, c);
        PLX_PTM_IVDEP
        for (int bx = start; bx < full; ++bx)
            r3[bx] = 2 * v3[bx] - (v1[bx] + v2[bx] - v0[bx]) - u3[bx];
        if (c == 0) return bad;
        // B's p11 correction as epsContexts' (c == 1: (p + p) >> 1 = p).
        const Lane* __restrict p3 = R.compRow(R.r3, c - 1);
        const Lane* __restrict q3 = R.compRow(R.r3, FastRows::secondBefore(c));
        PLX_PTM_IVDEP
        for (int bx = start; bx < full; ++bx) {
            ea[bx] += std::abs(r3[bx]) / 2;
            eb[bx] += std::abs(r3[bx] - ((p3[bx] + q3[bx]) >> 1)) / 2;
        }
    }
    return bad;
}

// Byte shuffles that interleave three planes of 16 bytes into 48: output byte g = 16 j + k is
// pixel g / 3 of plane g % 3; mask 3 j + ch picks plane ch's bytes of output vector j.
struct RgbShuffles {
    alignas(16) int8_t mask[9][16]{};
    constexpr RgbShuffles() {
        for (int j = 0; j < 3; ++j)
            for (int ch = 0; ch < 3; ++ch)
                for (int k = 0; k < 16; ++k) {
                    const int g = 16 * j + k;
                    mask[3 * j + ch][k] = g % 3 == ch ? int8_t(g / 3) : int8_t(-128);
                }
    }
};
inline constexpr RgbShuffles kRgbShuffles{};

// One pixel row of the full blocks of a block row, interleaved: pixels 2 bx and 2 bx + 1 of
// component c are a[c * full + bx] and b[c * full + bx] (planar rows of the walker).
// Values outside 0..255 (only in a level that fails eq. 3's range check, whose pixels are then
// discarded) may differ between the vector and the scalar path.
template <int C>
void writeFullRow(const Lane* __restrict a, const Lane* __restrict b, int full,
                  uint8_t* __restrict row) {
    const size_t n = size_t(full);
    size_t start = 0;
#if defined(__AVX2__)
    // Sixteen blocks (32 pixels) per step: each component's 16 + 16 values packed to bytes and
    // interleaved into one planar 32-pixel row, then the C planes interleaved by byte shuffles.
    auto bytes16 = [](const Lane* p) {
        auto ld = [p](int i) {
            return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 8 * i));
        };
        return _mm_packus_epi16(ld(0), ld(1));
    };
    for (; start + 16 <= n; start += 16) {
        __m128i lo[C], hi[C];  // pixels 0..15 and 16..31 of the step, per component
        for (size_t c = 0; c < size_t(C); ++c) {
            const __m128i va = bytes16(a + c * n + start), vb = bytes16(b + c * n + start);
            lo[c] = _mm_unpacklo_epi8(va, vb);
            hi[c] = _mm_unpackhi_epi8(va, vb);
        }
        uint8_t* out = row + 2 * start * C;
        for (int h = 0; h < 2; ++h) {
            const __m128i* q = h ? hi : lo;
            __m128i* o = reinterpret_cast<__m128i*>(out + size_t(h) * 16 * C);
            if constexpr (C == 1) {
                _mm_storeu_si128(o, q[0]);
            } else if constexpr (C == 2) {
                _mm_storeu_si128(o, _mm_unpacklo_epi8(q[0], q[1]));
                _mm_storeu_si128(o + 1, _mm_unpackhi_epi8(q[0], q[1]));
            } else if constexpr (C == 4) {
                const __m128i rg0 = _mm_unpacklo_epi8(q[0], q[1]);
                const __m128i rg1 = _mm_unpackhi_epi8(q[0], q[1]);
                const __m128i ba0 = _mm_unpacklo_epi8(q[2], q[3]);
                const __m128i ba1 = _mm_unpackhi_epi8(q[2], q[3]);
                _mm_storeu_si128(o, _mm_unpacklo_epi16(rg0, ba0));
                _mm_storeu_si128(o + 1, _mm_unpackhi_epi16(rg0, ba0));
                _mm_storeu_si128(o + 2, _mm_unpacklo_epi16(rg1, ba1));
                _mm_storeu_si128(o + 3, _mm_unpackhi_epi16(rg1, ba1));
            } else {
                const auto* sh = reinterpret_cast<const __m128i*>(kRgbShuffles.mask);
#pragma GCC unroll 3
                for (int j = 0; j < 3; ++j) {
                    const __m128i v0 = _mm_shuffle_epi8(q[0], _mm_load_si128(sh + 3 * j));
                    const __m128i v1 = _mm_shuffle_epi8(q[1], _mm_load_si128(sh + 3 * j + 1));
                    const __m128i v2 = _mm_shuffle_epi8(q[2], _mm_load_si128(sh + 3 * j + 2));
                    _mm_storeu_si128(o + j, _mm_or_si128(_mm_or_si128(v0, v1), v2));
                }
            }
        }
    }
#endif
PLX_PTM_IVDEP
    for (size_t bx = start; bx < n; ++bx) {
#pragma GCC unroll 4
        for (size_t c = 0; c < size_t(C); ++c) {
            row[2 * bx * C + c] = uint8_t(a[c * n + bx]);
            row[2 * bx * C + C + c] = uint8_t(b[c * n + bx]);
        }
    }
}

// The full blocks of a block row, coders 3 to 5: one run per stored position with every
// component (p00 of all components, then p10, p01, eps). Returns finishFullRow's flags.
template <int C, class IO>
unsigned walkFullRowByRun(FastRows& R, int lw, int full, IO& io) {
    uint16_t* ctx = R.ctx.data();
    const int n = C * full;
    for (int c = 0; c < C; ++c) fullRunContexts<0>(R, lw, full, c, io.ctxMap(c, 0));
    io.template run<true>(ctx, n, R.z0.data());
    for (int c = 0; c < C; ++c) fullRunContexts<1>(R, lw, full, c, io.ctxMap(c, 1));
    io.template run<true>(ctx, n, R.z1.data());
    for (int c = 0; c < C; ++c) fullRunContexts<2>(R, lw, full, c, io.ctxMap(c, 2));
    io.template run<true>(ctx, n, R.z2.data());
    if constexpr (!IO::kEncode)
        for (int c = 0; c < C; ++c) codeFullRow<false, false>(R, lw, full, c);
    for (int c = 0; c < C; ++c) epsContexts<IO::kEncode>(R, lw, full, c, io.ctxMap(c, 3));
    io.template run<false>(ctx, n, R.ze.data());
    unsigned bad = 0;
    for (int c = 0; c < C; ++c)
        bad |= R.models.above ? finishFullRow<true, false>(R, lw, full, c)
                              : finishFullRow<false, false>(R, lw, full, c);
    return bad;
}

// The full blocks of a block row, coder 6: component-major, each component's p00, p10 and p01
// runs, its pixels, its eps run and its p11 before the next component's, so that the next
// one's predictions and contexts see them. Four runs per component instead of four in all: the
// runs of a 1024-wide level stay 512 symbols long, sixteen vector rounds each.
template <int C, class IO>
unsigned walkFullRowByComponent(FastRows& R, int lw, int full, IO& io) {
    unsigned bad = 0;
    for (int c = 0; c < C; ++c) {
        const size_t ri = size_t(c) * size_t(full);
        uint16_t* ctx = R.ctx.data() + ri;
        fullRunContexts<0>(R, lw, full, c, io.ctxMap(c, 0));
        io.template run<true>(ctx, full, R.z0.data() + ri);
        fullRunContexts<1>(R, lw, full, c, io.ctxMap(c, 1));
        io.template run<true>(ctx, full, R.z1.data() + ri);
        fullRunContexts<2>(R, lw, full, c, io.ctxMap(c, 2));
        io.template run<true>(ctx, full, R.z2.data() + ri);
        if constexpr (!IO::kEncode) codeFullRow<false, true>(R, lw, full, c);
        epsContexts<IO::kEncode>(R, lw, full, c, io.ctxMap(c, 3));
        io.runEps(c, ctx, full, R.ze.data() + ri);
        bad |= finishFullRow<true, true>(R, lw, full, c);
    }
    return bad;
}

// Group k >= 1 of coders 3 to 6. Returns false (decode only) on an eps >= n or a pixel of eq. (3)
// outside 0..255.
template <int C, class IO>
bool walkLevelFast(const ByteImage& low, uint8_t* cur, int width, int height, IO& ioRef) {
    IO io = std::move(ioRef);  // a local whose address does not escape (see walkLevelRans)
    const int lw = low.width, lh = low.height, full = width / 2;  // full: 2-wide blocks per row
    const size_t stride = size_t(width) * C, lowStride = size_t(lw) * C;
    const size_t sw = size_t(lw + 2);
    FastRows R(C, lw, io.models);
    unsigned bad = 0;
    for (int by = 0; by < lh; ++by) {
        const int y0 = 2 * by, y1 = std::min(y0 + 1, height - 1);
        const bool tall = y1 > y0;  // blocks of this row have two pixel rows
        uint8_t* r0 = cur + size_t(y0) * stride;
        uint8_t* r1 = cur + size_t(y1) * stride;
        const uint8_t* lm = low.bytes.data() + size_t(by) * lowStride;
        const uint8_t* lu = low.bytes.data() + size_t(std::max(by - 1, 0)) * lowStride;
        const uint8_t* ld = low.bytes.data() + size_t(std::min(by + 1, lh - 1)) * lowStride;
        if (by == 0) {
            for (int c = 0; c < C; ++c) {
                planarRow<C>(lu, lw, c, R.pu.data() + size_t(c) * sw);
                planarRow<C>(lm, lw, c, R.pm.data() + size_t(c) * sw);
            }
        } else {  // rows by - 1 and by are the previous block row's by and by + 1
            std::swap(R.pu, R.pm);
            std::swap(R.pm, R.pd);
        }
        for (int c = 0; c < C; ++c) {
            planarRow<C>(ld, lw, c, R.pd.data() + size_t(c) * sw);
            if (R.models.above && tall)
                prepareRow<true>(R, lw, c, by == 0);
            else
                prepareRow<false>(R, lw, c, by == 0);
        }
        uint16_t* ctx = R.ctx.data();
        if (tall && full > 0) {
            if constexpr (IO::kEncode) {
                for (int bx = 0; bx < full; ++bx)
                    for (int c = 0; c < C; ++c) {
                        const size_t i = size_t(c) * size_t(full) + size_t(bx);
                        const size_t px = size_t(2 * bx) * C + size_t(c);
                        R.v0[i] = r0[px];
                        R.v1[i] = r0[px + C];
                        R.v2[i] = r1[px];
                        R.v3[i] = r1[px + C];
                    }
                for (int c = 0; c < C; ++c)
                    R.models.cross ? codeFullRow<true, true>(R, lw, full, c)
                                   : codeFullRow<true, false>(R, lw, full, c);
            }
            if (R.models.cross)
                bad |= walkFullRowByComponent<C>(R, lw, full, io);
            else
                bad |= walkFullRowByRun<C>(R, lw, full, io);
            if constexpr (!IO::kEncode) {
                writeFullRow<C>(R.v0.data(), R.v1.data(), full, r0);
                writeFullRow<C>(R.v2.data(), R.v3.data(), full, r1);
            }
        }
        // Blocks with two real pixels: the last column's 1x2 block (odd width) or the last
        // row's 2x1 blocks (odd height). p00 is coded, the other pixel follows from eq. (3).
        const int pairFrom = tall ? full : 0;
        const int pairTo = tall ? (width & 1 ? lw : full) : full;
        const int np = pairTo - pairFrom;
        if (np > 0) {
            for (int c = 0; c < C; ++c)
                for (int k = 0; k < np; ++k) {
                    const size_t j = size_t(c) * size_t(np) + size_t(k);
                    const size_t i = size_t(c) * size_t(lw) + size_t(pairFrom + k);
                    ctx[j] = uint16_t(io.ctxMap(c, 0)(bucketOf(R.act0[i])));
                    const int uo = tall ? R.u2[i] : R.u1[i];  // the other pixel: p01 or p10
                    const int pred = predictBlockPixel(2, R.m[i], 0, R.u0[i] + uo, 2, R.u0[i]);
                    R.v3[j] = pred;
                    if constexpr (IO::kEncode) {
                        const size_t px = size_t(2 * (pairFrom + k)) * C + size_t(c);
                        const int a = r0[px], o = tall ? r1[px] : r0[px + C];
                        R.z0[j] = uint8_t(zigzag(int(int8_t(uint8_t(a - pred)))));
                        R.ze[j] = uint8_t(a + o - 2 * R.m[i]);
                    }
                }
            const int cnt = C * np;
            io.template run<true>(ctx, cnt, R.z0.data());
            for (int j = 0; j < cnt; ++j)
                ctx[j] = uint16_t(io.ctxMap(j / np, 3)(kEpsContexts - 2));
            io.template run<false>(ctx, cnt, R.ze.data());
            for (int c = 0; c < C; ++c)
                for (int k = 0; k < np; ++k) {
                    const size_t j = size_t(c) * size_t(np) + size_t(k);
                    const size_t i = size_t(c) * size_t(lw) + size_t(pairFrom + k);
                    const int a = (R.v3[j] + unzigzagFast(R.z0[j])) & 255;
                    const int ep = R.ze[j];
                    const int last = 2 * R.m[i] + ep - a;  // eq. (3), n = 2
                    bad |= unsigned(ep >= 2) | unsigned(unsigned(last) > 255u);
                    const size_t px = size_t(2 * (pairFrom + k)) * C + size_t(c);
                    if constexpr (!IO::kEncode) {
                        r0[px] = uint8_t(a);
                        (tall ? r1[px] : r0[px + C]) = uint8_t(last);
                    }
                    const int e = magnitude(R.z0[j]);
                    const size_t s = size_t(c) * sw + size_t(pairFrom + k) + 1;
                    R.curAct[s] = 3 * e;
                    R.curEA[s] = 3 * e;
                    R.curEB[s] = 3 * e + 3;
                }
        }
        if (!tall && (width & 1)) {  // the 1x1 corner block: eps = 0, the pixel is its parent
            if constexpr (!IO::kEncode)
                for (int c = 0; c < C; ++c)
                    r0[size_t(width - 1) * C + size_t(c)] = lm[size_t(lw - 1) * C + size_t(c)];
        }
        for (int c = 0; c < C; ++c) {  // replicate the row's ends for the next row's diagonals
            for (auto* v : {&R.curAct, &R.curEA, &R.curEB}) {
                Lane* s = v->data() + size_t(c) * sw;
                s[0] = s[1];
                s[lw + 1] = s[lw];
            }
        }
        std::swap(R.prevAct, R.curAct);
        std::swap(R.prevEA, R.curEA);
        std::swap(R.prevEB, R.curEB);
    }
    ioRef = std::move(io);
    return bad == 0;
}

}  // namespace plx::ptm::detail
