#pragma once
// Runs of non-zero bytes in a row of a hole mask, found by the reprojection's row pass and by
// findHoles. Hole pixels are a few percent of a frame, so the zero bytes between them are
// skipped many at a time.

#include <cstdint>
#include <cstring>

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
#include <emmintrin.h>
#endif

namespace plx::stereo {

// The first column >= x whose mask byte is not zero, or width. Hole pixels are a few percent of a
// frame, so the zero bytes between them are skipped 64 at a time (SSE2) or 8 at a time.
inline int nextNonZero(const uint8_t* m, int x, int width) {
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
    const __m128i zero = _mm_setzero_si128();
    auto load = [&](int at) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(m + at)); };
    for (; x + 64 <= width; x += 64) {
        const __m128i any = _mm_or_si128(_mm_or_si128(load(x), load(x + 16)),
                                         _mm_or_si128(load(x + 32), load(x + 48)));
        if (_mm_movemask_epi8(_mm_cmpeq_epi8(any, zero)) != 0xffff) break;
    }
    for (; x + 16 <= width; x += 16) {
        const int nonZero = ~_mm_movemask_epi8(_mm_cmpeq_epi8(load(x), zero)) & 0xffff;
        if (nonZero != 0) return x + __builtin_ctz(unsigned(nonZero));
    }
#endif
    for (; x + 8 <= width; x += 8) {
        uint64_t word;
        std::memcpy(&word, m + x, sizeof word);
        if (word != 0) break;
    }
    while (x < width && !m[x]) ++x;
    return x;
}

// Calls run(start, end) for each maximal run [start, end) of non-zero bytes of m[0, width), left
// to right.
template <class Run>
void forEachNonZeroRun(const uint8_t* m, int width, const Run& run) {
    for (int x = 0; x < width;) {
        if (!m[x]) {
            x = nextNonZero(m, x + 1, width);
            continue;
        }
        const int start = x;
        while (x < width && m[x]) ++x;
        run(start, x);
    }
}

}  // namespace plx::stereo
