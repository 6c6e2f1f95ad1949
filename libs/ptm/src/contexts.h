#pragma once
// Private: the contexts of the modelled coder (docs/ptm-format.md, "Contexts"). A group's
// symbols are split into families (4 per component: the stored positions p00, p10, p01 and
// eps); each family has raw contexts that the group's context map merges into its tables. The
// walker computes a whole run's contexts before the entropy decoder reads the run.

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>

#include "rows.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// Context layout: family f (16 raw contexts each) = 4 * component + kind, kind 0..2 the stored
// positions p00, p10, p01 (or the smallest level's pixels, kind 0 of group 0), kind 3 eps.
inline constexpr int kFamilyContexts = 16;
inline constexpr int kActivityBuckets = 12;  // raw pixel contexts per family
inline constexpr int kEpsContexts = 16;      // raw eps contexts per family
inline constexpr int kMaxRawContexts = 16 * kFamilyContexts;

// Raw contexts of family kind (pixel families have 12, eps families 16).
inline int familyRawContexts(int kind) { return kind == 3 ? kEpsContexts : kActivityBuckets; }

// Families present in a group: group 0 has one per component (kind 0), others four.
inline int familyCount(int comps, bool lowest) { return lowest ? comps : 4 * comps; }
inline int familyId(int i, bool lowest) { return lowest ? 4 * i : i; }

// Raw context id (family 4c + kind, raw context q).
inline int rawCtx(int c, int kind, int q) { return (4 * c + kind) * kFamilyContexts + q; }

// The context ids a walker writes for family (c, kind): raw context q becomes
// `base + ((q * mul) >> 13)`. The encoder uses the raw ids (base = rawCtx(c, kind, 0), mul =
// 8192); the decoder maps straight to the family's table index `first + q * g / R` of the
// context map (exact with mul = 683 g for R = 12, q * g <= 132, and mul = 512 g for R = 16).
struct CtxMap {
    int base = 0;
    int mul = 8192;
    int operator()(int q) const { return base + ((q * mul) >> 13); }
};
inline CtxMap rawCtxMap(int c, int kind) { return {rawCtx(c, kind, 0), 8192}; }

// Activity (about 9 absolute residuals) to bucket 0..11 by thresholds on a rough log scale,
// by comparisons, so that loops over a row vectorise.
constexpr int bucketOf(int a) {
    return (a >= 2) + (a >= 4) + (a >= 6) + (a >= 9) + (a >= 12) + (a >= 16) + (a >= 21) +
           (a >= 28) + (a >= 38) + (a >= 52) + (a >= 72);
}


#if defined(__AVX2__)
namespace avx2 {
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
RunContextRows runContextRows(LevelRows& R, int lw, int full, int c) {
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
bool fullRunContextsAvx2(LevelRows& R, int lw, int full, int c, CtxMap map, bool cross) {
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
bool fullRunContextsAvx512(LevelRows& R, int lw, int full, int c, CtxMap map, bool cross) {
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
void fullRunContexts(LevelRows& R, int lw, int full, int c, CtxMap map) {
#if defined(__AVX2__)
    if constexpr (kFast) {
        const bool cross = c > 0;
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
    if (c == 0) return contexts([](int) { return 0; });
    // The previous component's magnitudes in the same block, decoded before this run
    // (component-major rows): the same position weighted 1, each of its three stored pixels
    // 1/2 (docs/ptm-format.md, "Contexts").
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
// epsContexts' contexts (decode) for blocks 0..kLanes k - 1, W::kLanes blocks per step
// in int16 lanes (every term within +-11000, also in a corrupt level). Bit-exact with the scalar
// loop, which does the rest. Returns the first block not done (0 when `map` does not fit a byte
// lookup).
template <class W>
int crossEpsContextsVec(LevelRows& R, int lw, int full, int c, CtxMap map) {
    using V = typename W::V;
    avx2::CtxLut ctxOf;
    if (!ctxOf.make(map, kEpsContexts)) return 0;
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* r3 = R.compRow(R.r3, c - 1);
    const Lane* q3 = R.compRow(R.r3, LevelRows::secondBefore(c));
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
// With AVX2, the decoder's contexts of the first blocks by crossEpsContextsVec in the
// widest lanes the ISA has (W, as prepareRow's); kFast = false runs the scalar loop for every
// block (the reference of fast_paths_test).
template <bool kEncode, bool kFast = true, class W = WidestLanes>
void epsContexts(LevelRows& R, int lw, int full, int c, CtxMap map) {
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
    // p11 predicted by the mean of the planar p10 + p01 - p00 and the bilinear upsample u3, in
    // half steps (eHalf is twice the eps that prediction implies), plus sub-predictor B where
    // `sel` picks it: the previous component's p11 residual r3, for components >= 2 the mean of
    // the two before. Five eps values around the prediction and three activity levels, which
    // also count the previous component's |r3| (docs/ptm-format.md, "Contexts").
    const Lane* __restrict u3 = R.u3.data() + pi;
    const Lane* __restrict sel = R.sel.data() + pi;
    // The two components before (LevelRows::secondBefore).
    const Lane* __restrict r3 = R.compRow(R.r3, c - 1);
    const Lane* __restrict q3 = R.compRow(R.r3, LevelRows::secondBefore(c));
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
}

}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
