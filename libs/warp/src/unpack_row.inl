// The unpack of one destination row (row_kernel.h), compiled once per ISA
// (plx_add_isa_kernels): packed words to colour, 1/w and hole mask, the words cleared for the
// next frame. With AVX2 eight words per step; the same bits as the scalar loop.

#include <bit>
#include <cstdint>
#include <cstring>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "row_kernel.h"

namespace plx::warp::detail::PLX_ISA_NS {

int unpackRow(uint64_t* words, int width, uint32_t clearBits, Rgba8* color, float* depth,
              uint8_t* holeMask) {
    int holes = 0;
    int x = 0;
#if defined(__AVX2__)
    const __m256i zero = _mm256_setzero_si256();
    const __m256i one = _mm256_set1_epi32(1);
    const __m256i clear = _mm256_set1_epi32(int32_t(clearBits));
    for (; x + 8 <= width; x += 8) {
        __m256i* q = reinterpret_cast<__m256i*>(words + x);
        const __m256 w0 = _mm256_castsi256_ps(_mm256_loadu_si256(q));
        const __m256 w1 = _mm256_castsi256_ps(_mm256_loadu_si256(q + 1));
        _mm256_storeu_si256(q, zero);
        _mm256_storeu_si256(q + 1, zero);
        // Low halves (colours) and high halves (keys) of the eight words, in order.
        const __m256i colors = _mm256_permute4x64_epi64(
            _mm256_castps_si256(_mm256_shuffle_ps(w0, w1, _MM_SHUFFLE(2, 0, 2, 0))),
            _MM_SHUFFLE(3, 1, 2, 0));
        const __m256i keys = _mm256_permute4x64_epi64(
            _mm256_castps_si256(_mm256_shuffle_ps(w0, w1, _MM_SHUFFLE(3, 1, 3, 1))),
            _MM_SHUFFLE(3, 1, 2, 0));
        const __m256i hole = _mm256_cmpeq_epi32(keys, zero);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(color + x),
                            _mm256_blendv_epi8(colors, clear, hole));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(depth + x),
                            _mm256_andnot_si256(hole, _mm256_sub_epi32(keys, one)));
        const unsigned bits = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(hole)));
        const uint64_t bytes = _pdep_u64(bits, 0x0101010101010101ull);
        std::memcpy(holeMask + x, &bytes, 8);
        holes += __builtin_popcount(bits);
    }
#endif
    for (; x < width; ++x) {
        const uint64_t v = words[x];
        words[x] = 0;
        const uint32_t key = uint32_t(v >> 32);
        const bool hole = key == 0;
        holeMask[x] = hole;
        holes += hole;
        color[x] = std::bit_cast<Rgba8>(hole ? clearBits : uint32_t(v));
        depth[x] = std::bit_cast<float>(hole ? 0u : key - 1u);  // key: bits of 1/w, plus 1
    }
    return holes;
}

}  // namespace plx::warp::detail::PLX_ISA_NS
