// The z-buffer splat of one transformed row into a destination band (row_kernel.h), compiled
// once per ISA (plx_add_isa_kernels). A splat is at most 7 pixels wide (kMaxSplatSize 6 plus
// the rounding of its ends), so with AVX2 each of its rows is one to three aligned 4-word
// blocks: load, compare, blend, store. The result is the same max per word as the scalar path.

#include <algorithm>
#include <bit>
#include <cstdint>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "row_kernel.h"

namespace plx::warp::detail::PLX_ISA_NS {

void splatRow(const SplatRowInput& in) {
#if defined(__AVX2__)
    const __m256i lanes = _mm256_setr_epi64x(0, 1, 2, 3);
#endif
    for (int i = 0; i < in.count; ++i) {
        const int32_t x0 = in.rx0[i], x1 = in.rx1[i];
        const int32_t y0 = std::max(in.ry0[i], in.bandY0), y1 = std::min(in.ry1[i], in.bandY1);
        if (x0 >= x1 || y0 >= y1) continue;
        const uint32_t color =
            in.disparity[i] > 0.0f ? std::bit_cast<uint32_t>(in.color[i]) : in.clearBits;
        const uint64_t v = uint64_t(in.key[i]) << 32 | color;
        uint64_t* row = in.words + size_t(y0) * in.stride;
#if defined(__AVX2__)
        // Aligned 4-word blocks: a load then always meets an earlier store to the same 32 bytes,
        // which the CPU forwards; unaligned vectors straddling the last splat's stores did not
        // (a stall on most loads). Keys are below 2^31 (the bits of a non-negative float, plus
        // one), so words are below 2^63 and the signed compare orders them.
        const __m256i vv = _mm256_set1_epi64x(int64_t(v));
        const __m256i lo = _mm256_set1_epi64x(x0 - 1);
        const __m256i hi = _mm256_set1_epi64x(x1);
        const int32_t b0 = x0 & ~3, b1 = (x1 - 1) & ~3;
        for (int32_t y = y0; y < y1; ++y, row += in.stride) {
            for (int32_t b = b0; b <= b1; b += 4) {
                const __m256i idx = _mm256_add_epi64(_mm256_set1_epi64x(b), lanes);
                const __m256i inside =
                    _mm256_and_si256(_mm256_cmpgt_epi64(idx, lo), _mm256_cmpgt_epi64(hi, idx));
                __m256i* q = reinterpret_cast<__m256i*>(row + b);
                const __m256i old = _mm256_load_si256(q);
                const __m256i gt = _mm256_and_si256(inside, _mm256_cmpgt_epi64(vv, old));
                _mm256_store_si256(q, _mm256_blendv_epi8(old, vv, gt));
            }
        }
#else
        for (int32_t y = y0; y < y1; ++y, row += in.stride)
            for (int32_t x = x0; x < x1; ++x) row[x] = v > row[x] ? v : row[x];
#endif
    }
}

}  // namespace plx::warp::detail::PLX_ISA_NS
