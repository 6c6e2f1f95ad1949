#pragma once
// Private: the lane vocabulary of the PTM kernels (docs/ptm-format.md). The walker's per-block
// values are int16 lanes; Lanes16 (AVX2) and Lanes32 (AVX-512) name one vector width's
// operations on them, so that each vector pass is written once for both widths. Included only
// by the kernel headers; the ISA is the translation unit's (kernel_ns.h).

#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#if defined(__AVX2__)
#include <immintrin.h>
#endif
// The AVX-512 passes need F, BW and VL; the avx512 tier (x86-64-v4) always has them.
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)
#define PLX_PTM_AVX512 1
#else
#define PLX_PTM_AVX512 0
#endif

#include "kernel_ns.h"

// Loop hints: rows of different arrays never overlap (ivdep); keep the rANS states scalar.
#if defined(__clang__)  // the fuzzing build; no hints (clang warns where it cannot follow them)
#define PLX_PTM_IVDEP
#define PLX_PTM_NO_SLP
#else
#define PLX_PTM_IVDEP _Pragma("GCC ivdep")
#define PLX_PTM_NO_SLP __attribute__((optimize("no-tree-slp-vectorize")))
#endif

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// The walker's per-block values (pixels, predictions, residuals, activities, statistics) as
// int16: every stored value lies within +-3500, also in a corrupt level (p11 within -765..1275,
// its half-step residual r3 within +-3400), so a vector holds sixteen (AVX2) or 32 (AVX-512)
// and the rows take half the cache of int (docs/ptm-format.md, "Decoder").
using Lane = int16_t;

// The allocator of the kernels' rows: a type of this namespace, so that each ISA's row
// vectors are distinct instantiations and the linker never hands one ISA's copy to another.
template <class T>
struct RowAllocator {
    using value_type = T;
    RowAllocator() = default;
    template <class U>
    RowAllocator(const RowAllocator<U>&) {}
    T* allocate(size_t n) { return static_cast<T*>(::operator new(n * sizeof(T))); }
    void deallocate(T* p, size_t) { ::operator delete(p); }
    template <class U>
    bool operator==(const RowAllocator<U>&) const { return true; }
};
template <class T>
using Row = std::vector<T, RowAllocator<T>>;

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
    template <class Lut>
    static V contexts(const Lut& map, V q) { return map(q); }  // q in 0..15
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
    template <class Lut>
    static V contexts(const Lut& map, V q) {
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

}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
