// The row scan of VisibleSetCollector (visible_set.cpp), compiled once per ISA
// (plx_add_isa_kernels); the avx2 and avx512 units take the 8-wide loop.

#include <cstddef>
#include <cstdint>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace plx::raster::detail::PLX_ISA_NS {

namespace {

// Writes id - 1 to starts[] for every pixel of one ID-target row p[0..n) whose non-zero ID
// differs from both the pixel before it and the pixel above it (above[0..n), the row before;
// null for none), and returns how many it wrote (at most n). A polygon's pixels form runs, and
// a run mostly continues one in the row above: of the 18.3k run starts of office:280's 640x480
// first eye, 6.0k also differ from the pixel above (BM_CollectPass: 15% less CPU time). No ID
// is missed: in scan order, the first pixel of an ID has neither neighbour of that ID. An ID may
// still be written more than once; the collector keeps its set free of repeats.
// With AVX2 eight pixels are compared with their neighbours at once, and only the lanes that
// remain are visited. Most groups of eight repeat the row above outright, and are passed over
// after that one comparison: 3.8 -> 2.3 instructions per pixel (callgrind, office:280's first
// eye), BM_CollectPass 130-175 -> 84-90 us.
size_t rowRunStarts(const uint32_t* p, const uint32_t* above, size_t n, uint32_t* starts) {
    size_t count = 0;
    size_t i = 0;
#if defined(__AVX2__)
    const __m256i shiftRight = _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6);
    const __m256i zero = _mm256_setzero_si256();
    // Writes the lanes of v (pixels g .. g+7) that are neither in `same` nor 0 nor equal to their
    // left neighbour (pixel g + k - 1; none left of the row's first pixel).
    auto startsOfGroup = [&](size_t g, __m256i v, __m256i same) {
        __m256i left =
            g ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + g - 1))
              : _mm256_blend_epi32(_mm256_permutevar8x32_epi32(v, shiftRight), zero, 0x01);
        same = _mm256_or_si256(
            same, _mm256_or_si256(_mm256_cmpeq_epi32(v, left), _mm256_cmpeq_epi32(v, zero)));
        for (unsigned lanes = ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(same))) & 0xFFu;
             lanes; lanes &= lanes - 1)
            starts[count++] = p[g + size_t(__builtin_ctz(lanes))] - 1;
    };
    if (above) {
        for (; i + 8 <= n; i += 8) {
            __m256i v = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i));
            __m256i up = _mm256_cmpeq_epi32(
                v, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(above + i)));
            if (_mm256_movemask_ps(_mm256_castsi256_ps(up)) != 0xFF) startsOfGroup(i, v, up);
        }
    } else {
        for (; i + 8 <= n; i += 8)
            startsOfGroup(i, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i)), zero);
    }
#endif
    uint32_t previous = i ? p[i - 1] : 0;
    for (; i < n; ++i) {
        if (p[i] != previous && p[i] != 0 && !(above && p[i] == above[i]))
            starts[count++] = p[i] - 1;
        previous = p[i];
    }
    return count;
}

}  // namespace

// The run starts of the rows *row, *row + 1, ... of a rectangle `width` pixels wide whose first
// row starts at `origin` (rows `stride` elements apart; the first row has no row above), up to
// row `rows` - 1 or until the next row might not fit in what is left of `capacity` (>= width).
// Returns how many it wrote to starts[] and leaves in *row the first row not scanned. One call
// per rectangle rather than per row: a call per row cost the pass over office:280's first eye
// about 9% (BM_CollectPass).
size_t findRunStarts(const uint32_t* origin, ptrdiff_t stride, size_t width, int rows, int* row,
                     uint32_t* starts, size_t capacity) {
    size_t count = 0;
    for (; *row < rows && count + width <= capacity; ++*row) {
        const uint32_t* p = origin + ptrdiff_t(*row) * stride;
        count += rowRunStarts(p, *row > 0 ? p - stride : nullptr, width, starts + count);
    }
    return count;
}

}  // namespace plx::raster::detail::PLX_ISA_NS
