// The reprojection's row kernels (row_pass.h), compiled once per ISA (plx_add_isa_kernels): the
// scalar unit steps four pixels at a time with SSE2 (one at a time in a PLX_NO_SIMD build, the
// reference), the avx2 unit eight with AVX2. Every path writes the same landings and pixels.

#include <cstring>

#include <plx/stereo/reproject.h>

#include "row_pass.h"

#if defined(__AVX2__)
#include <immintrin.h>
#define PLX_ROW_AVX2 1
#elif defined(__SSE2__) && !defined(PLX_NO_SIMD)
#include <emmintrin.h>
#define PLX_ROW_SSE2 1
#endif

namespace plx::stereo::detail::PLX_ISA_NS {

namespace {

// The offset of a first-eye pixel of 1/w v, the pixel centre's 0.5 included: the direct form's
// a v + b, or the table's entry (OffsetLut::centredOffset), for one pixel and for a vector of
// them with the same float operations in the same order (the build does not contract them).
struct DirectOffset {
    float a, b;
    float operator()(float v) const { return a * v + b; }
#if PLX_ROW_AVX2
    __m256 operator()(__m256 v) const {
        return _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(a), v), _mm256_set1_ps(b));
    }
#elif PLX_ROW_SSE2
    __m128 operator()(__m128 v) const {
        return _mm_add_ps(_mm_mul_ps(_mm_set1_ps(a), v), _mm_set1_ps(b));
    }
#endif
};

// The vector forms clamp with max, which returns its second operand, 0, for a NaN first, as the
// scalar form's test does.
struct TableOffset {
    OffsetTable t;
    float operator()(float v) const { return t.table[OffsetLut::entryIndex(v, t.scale, t.last)]; }
#if PLX_ROW_AVX2
    __m256 operator()(__m256 v) const {
        __m256 q = _mm256_add_ps(_mm256_mul_ps(v, _mm256_set1_ps(t.scale)), _mm256_set1_ps(0.5f));
        q = _mm256_min_ps(_mm256_max_ps(q, _mm256_setzero_ps()), _mm256_set1_ps(t.last));
        return _mm256_i32gather_ps(t.table, _mm256_cvttps_epi32(q), 4);
    }
#elif PLX_ROW_SSE2
    __m128 operator()(__m128 v) const {
        __m128 q = _mm_add_ps(_mm_mul_ps(v, _mm_set1_ps(t.scale)), _mm_set1_ps(0.5f));
        q = _mm_min_ps(_mm_max_ps(q, _mm_setzero_ps()), _mm_set1_ps(t.last));
        alignas(16) int32_t i[4];
        _mm_store_si128(reinterpret_cast<__m128i*>(i), _mm_cvttps_epi32(q));
        return _mm_setr_ps(t.table[i[0]], t.table[i[1]], t.table[i[2]], t.table[i[3]]);
    }
#endif
};

// One landing: first-eye column x lands at x + offset(1/w), in the pixel floor() of it. The
// range test in float also drops positions too large for int (and NaN); those land in the spare
// slot w.
template <class Offset>
int landOne(const RowScatter& row, const Offset& offset, int x) {
    const float pos = float(x) + offset(row.srcDepth[x]);
    const int t = pos >= 0.0f && pos < float(row.w) ? int(pos) : row.w;
    row.from[t] = row.tag + x;
    row.color[t] = row.srcColor[x];
    return t;
}

// Column x landed at slot t right after its neighbour (x - 1 walking left to right, x + 1 right
// to left) landed at prevSlot (the spare slot w for none yet when walking left to right, -1
// when walking right to left): where the two lie two or more slots apart in their columns'
// order, a RowGap. Returns t, the next one's prevSlot.
[[gnu::always_inline]] inline int follow(const RowScatter& row, int prevSlot, int t, int x,
                                         bool leftToRight) {
    const int apart = leftToRight ? t - prevSlot : prevSlot - t;
    if (apart >= 2 && prevSlot < row.w && t < row.w) [[unlikely]]
        row.gaps[(*row.gapCount)++] = {prevSlot, t, leftToRight ? x - 1 : x + 1, x};
    return t;
}

// The same for n landings stored at once in consecutive slots from t0, of columns x .. x + n - 1:
// only the first of them in occlusion-compatible order can lie apart from its neighbour.
[[gnu::always_inline]] inline int followRun(const RowScatter& row, int prevSlot, int t0, int x,
                                            int n, bool leftToRight) {
    if (leftToRight) {
        follow(row, prevSlot, t0, x, true);
        return t0 + n - 1;
    }
    follow(row, prevSlot, t0 + n - 1, x + n - 1, false);
    return t0;
}

// Columns [x0, x1) one by one in occlusion-compatible order.
// Returns the last landing's slot (follow).
template <class Offset>
int landRange(const RowScatter& row, const Offset& offset, int x0, int x1, bool leftToRight,
              int prevSlot) {
    if (leftToRight)
        for (int x = x0; x < x1; ++x)
            prevSlot = follow(row, prevSlot, landOne(row, offset, x), x, true);
    else
        for (int x = x1 - 1; x >= x0; --x)
            prevSlot = follow(row, prevSlot, landOne(row, offset, x), x, false);
    return prevSlot;
}

#if PLX_ROW_SSE2 || PLX_ROW_AVX2
// The landings of columns x .. x + n - 1 into the slots slot[0 .. n), one by one in
// occlusion-compatible order.
void storeLanes(const RowScatter& row, const int32_t* slot, int x, int n, bool leftToRight) {
    for (int i = 0; i < n; ++i) {
        const int k = leftToRight ? i : n - 1 - i;
        row.from[slot[k]] = row.tag + x + k;
        row.color[slot[k]] = row.srcColor[x + k];
    }
}

// Where the shift changes at first-eye column x, landing at slot t, a hole may open: the first
// eye's ID lines there are read ahead for markHoleRuns, which reads the IDs beside each run and,
// for a colour-only second eye in the first eye's planes, writes its marks there. The planes
// come from memory (the first eye streams them), so the row's write-out would otherwise wait on
// each line.
void readAheadIds(const RowScatter& row, int x, int t) {
    if (!row.readAheadId) return;
    _mm_prefetch(reinterpret_cast<const char*>(row.readAheadId + x), _MM_HINT_T0);
    if (t < row.w) _mm_prefetch(reinterpret_cast<const char*>(row.readAheadId + t), _MM_HINT_T0);
}

// Four landings one column apart, as a surface's pixels mostly land (its disparity changes by a
// small fraction of a pixel per column), stored as one vector each of columns and colours: their
// slots are distinct, so the order in which they are written does not matter.
void storeFour(const RowScatter& row, int x, int t0) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(row.from + t0),
                     _mm_add_epi32(_mm_set1_epi32(row.tag + x), _mm_set_epi32(3, 2, 1, 0)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(row.color + t0),
                     _mm_loadu_si128(reinterpret_cast<const __m128i*>(row.srcColor + x)));
}
#endif

#if PLX_ROW_AVX2
constexpr int kLanes = 8;

// The landings of columns x .. x + 7 into `slot` when their shifts differ (one group in nine on
// office:280): each half of four that shares one shift as one vector, the rest one by one, in
// occlusion-compatible order. Out of line, so that the walk over the row keeps its registers.
[[gnu::noinline]] int landMixedGroup(const RowScatter& row, __m256i slot, int x, bool leftToRight,
                                     int prevSlot) {
    const __m256i xi =
        _mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256i shift = _mm256_sub_epi32(slot, xi);
    const __m256i firstOfHalf =
        _mm256_permutevar8x32_epi32(shift, _mm256_setr_epi32(0, 0, 0, 0, 4, 4, 4, 4));
    const unsigned halves =
        unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(shift, firstOfHalf))));
    alignas(32) int32_t tx[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(tx), slot);
    readAheadIds(row, x, tx[0]);
    for (int i = 0; i < 2; ++i) {
        const int h = leftToRight ? i : 1 - i;
        if ((halves >> (4 * h) & 0xFu) == 0xFu)
            storeFour(row, x + 4 * h, tx[4 * h]);
        else
            storeLanes(row, tx + 4 * h, x + 4 * h, 4, leftToRight);
    }
    // Then follow for the group's first landing in occlusion-compatible order and each pair of
    // neighbours, the pairs two or more slots apart inside the row found at once (the gaps are
    // closed after the row, so their order does not matter).
    const __m256i next =
        _mm256_permutevar8x32_epi32(slot, _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7));
    const __m256i w = _mm256_set1_epi32(row.w);
    const __m256i gap = _mm256_and_si256(
        _mm256_cmpgt_epi32(_mm256_sub_epi32(next, slot), _mm256_set1_epi32(1)),
        _mm256_and_si256(_mm256_cmpgt_epi32(w, slot), _mm256_cmpgt_epi32(w, next)));
    for (unsigned pairs = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(gap))); pairs != 0;
         pairs &= pairs - 1) {
        const int i = __builtin_ctz(pairs);
        row.gaps[(*row.gapCount)++] = {tx[i], tx[i + 1], x + i, x + i + 1};
    }
    follow(row, prevSlot, leftToRight ? tx[0] : tx[7], leftToRight ? x : x + 7, leftToRight);
    return leftToRight ? tx[7] : tx[0];
}

// The whole groups of eight columns [0, groups) in occlusion-compatible order, each landed with
// the same float operations in the same order as landOne: eight at once when they land one
// column apart, as a surface's pixels mostly do, else landMixedGroup.
template <class Offset>
int landGroups(const RowScatter& row, const Offset& offset, int groups, bool leftToRight,
               int prevSlot) {
    const RowScatter r = row;  // a copy in locals: the landings' stores could alias `row`
    const __m256 width = _mm256_set1_ps(float(r.w));
    const __m256i spare = _mm256_set1_epi32(r.w), tag = _mm256_set1_epi32(r.tag),
                  iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    auto land = [&](int x) {
        const __m256i xi = _mm256_add_epi32(_mm256_set1_epi32(x), iota);
        const __m256 pos =
            _mm256_add_ps(_mm256_cvtepi32_ps(xi), offset(_mm256_loadu_ps(r.srcDepth + x)));
        // Inside [0, w) (false for NaN): its column; else the spare slot.
        const __m256 inside = _mm256_and_ps(_mm256_cmp_ps(pos, _mm256_setzero_ps(), _CMP_GE_OQ),
                                            _mm256_cmp_ps(pos, width, _CMP_LT_OQ));
        const __m256i slot = _mm256_blendv_epi8(
            spare, _mm256_cvttps_epi32(_mm256_and_ps(pos, inside)), _mm256_castps_si256(inside));
        // One shift for all eight: their slots are consecutive. Slots in the spare one never
        // are (the shift differs by lane), so such lanes all lie inside the row.
        const __m256i shift = _mm256_sub_epi32(slot, xi);
        const __m256i first = _mm256_broadcastd_epi32(_mm256_castsi256_si128(shift));
        if (_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(shift, first))) != 0xFF) {
            // `row`, not `r`: passing the copy's address out of line would let the stores
            // above alias it again.
            prevSlot = landMixedGroup(row, slot, x, leftToRight, prevSlot);
            return;
        }
        const int t0 = _mm256_cvtsi256_si32(slot);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(r.from + t0), _mm256_add_epi32(xi, tag));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(r.color + t0),
                            _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.srcColor + x)));
        prevSlot = followRun(row, prevSlot, t0, x, kLanes, leftToRight);
    };
    if (leftToRight)
        for (int x = 0; x < groups; x += kLanes) land(x);
    else
        for (int x = groups - kLanes; x >= 0; x -= kLanes) land(x);
    return prevSlot;
}
#elif PLX_ROW_SSE2
constexpr int kLanes = 4;

// After a group's landings of columns x .. x + n - 1 at slots tx[0 .. n) are stored: follow for
// the group's first in occlusion-compatible order after prevSlot, and for each pair of
// neighbours among them (the gaps are closed after the row, so their order does not matter).
// Returns the group's last slot in that order.
int followGroup(const RowScatter& row, const int32_t* tx, int x, int n, int prevSlot,
                bool leftToRight) {
    follow(row, prevSlot, leftToRight ? tx[0] : tx[n - 1], leftToRight ? x : x + n - 1,
           leftToRight);
    for (int i = 0; i + 1 < n; ++i) follow(row, tx[i], tx[i + 1], x + i + 1, true);
    return leftToRight ? tx[n - 1] : tx[0];
}

// Lands columns x .. x + 3 with the same float operations in the same order as landOne: as one
// vector when they land one column apart, else one by one in occlusion-compatible order.
template <class Offset>
int landGroup(const RowScatter& row, const Offset& offset, int x, bool leftToRight, int prevSlot) {
    const __m128i xi = _mm_add_epi32(_mm_set1_epi32(x), _mm_set_epi32(3, 2, 1, 0));
    const __m128 pos = _mm_add_ps(_mm_cvtepi32_ps(xi), offset(_mm_loadu_ps(row.srcDepth + x)));
    // Inside [0, w) (false for NaN): its column; else the spare slot.
    const __m128 inside = _mm_and_ps(_mm_cmpge_ps(pos, _mm_setzero_ps()),
                                     _mm_cmplt_ps(pos, _mm_set1_ps(float(row.w))));
    const __m128i col = _mm_cvttps_epi32(_mm_and_ps(pos, inside));
    const __m128i in = _mm_castps_si128(inside);
    const __m128i slot =
        _mm_or_si128(_mm_and_si128(in, col), _mm_andnot_si128(in, _mm_set1_epi32(row.w)));
    // One shift for all four: the slots are consecutive. Slots in the spare one never are (the
    // shift differs by lane), so all four lie inside the row.
    const __m128i shift = _mm_sub_epi32(slot, xi);
    const __m128i same = _mm_cmpeq_epi32(shift, _mm_shuffle_epi32(shift, 0));
    if (_mm_movemask_epi8(same) == 0xffff) {
        const int t0 = _mm_cvtsi128_si32(slot);
        storeFour(row, x, t0);
        return followRun(row, prevSlot, t0, x, kLanes, leftToRight);
    }
    alignas(16) int32_t tx[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(tx), slot);
    readAheadIds(row, x, tx[0]);
    storeLanes(row, tx, x, 4, leftToRight);
    return followGroup(row, tx, x, 4, prevSlot, leftToRight);
}

// The whole groups of four columns [0, groups) in occlusion-compatible order.
template <class Offset>
int landGroups(const RowScatter& row, const Offset& offset, int groups, bool leftToRight,
               int prevSlot) {
    const RowScatter r = row;  // a copy in locals: the landings' stores could alias `row`
    if (leftToRight)
        for (int x = 0; x < groups; x += kLanes) prevSlot = landGroup(r, offset, x, true, prevSlot);
    else
        for (int x = groups - kLanes; x >= 0; x -= kLanes)
            prevSlot = landGroup(r, offset, x, false, prevSlot);
    return prevSlot;
}
#endif

// One pixel of RowWrite; returns whether it is a hole.
bool writeOne(const RowWrite& r, int t) {
    const bool landed = r.from[t] >= r.tag;
    const int32_t s = landed ? r.from[t] - r.tag : 0;
    r.dstColor[t] = landed ? r.landedColor[t] : Rgba8{};
    r.hole[t] = uint8_t(!landed);
    if (r.srcDepth) {
        r.dstDepth[t] = landed ? r.srcDepth[s] : 0;
        r.dstId[t] = landed ? r.srcId[s] : 0;
    }
    return !landed;
}

#if PLX_ROW_AVX2
// Pixels [t, end of the last whole step) eight a step, colour by streaming stores (the caller
// aligned dstColor + t to 32 bytes), depth and ID by ordinary ones (writeRowPixels); returns
// the column after them.
int writeVectors(const RowWrite& row, int t, bool* anyHole) {
    const RowWrite r = row;  // a copy in locals: the hole bytes' stores could alias `row`
    const __m256i tag = _mm256_set1_epi32(r.tag);
    __m256i anyMissed = _mm256_setzero_si256();
    for (; t + 8 <= r.w; t += 8) {
        const __m256i f = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.from + t));
        const __m256i missed = _mm256_cmpgt_epi32(tag, f);
        anyMissed = _mm256_or_si256(anyMissed, missed);
        const __m256i color =
            _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.landedColor + t));
        _mm256_stream_si256(reinterpret_cast<__m256i*>(r.dstColor + t),
                            _mm256_andnot_si256(missed, color));
        if (r.srcDepth) {
            // Column 0 where none landed, then zeroed.
            const __m256i at = _mm256_andnot_si256(missed, _mm256_sub_epi32(f, tag));
            _mm256_storeu_si256(
                reinterpret_cast<__m256i*>(r.dstDepth + t),
                _mm256_andnot_si256(missed, _mm256_i32gather_epi32(r.srcDepth, at, 4)));
            _mm256_storeu_si256(
                reinterpret_cast<__m256i*>(r.dstId + t),
                _mm256_andnot_si256(missed, _mm256_i32gather_epi32(r.srcId, at, 4)));
        }
        // The eight mask bits spread to one byte each.
        const unsigned bits = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(missed)));
        const uint64_t bytes = _pdep_u64(bits, 0x0101010101010101ull);
        std::memcpy(r.hole + t, &bytes, 8);
    }
    *anyHole |= !_mm256_testz_si256(anyMissed, anyMissed);
    return t;
}
constexpr uintptr_t kStreamAlign = 32;
#elif PLX_ROW_SSE2
// Pixels [t, end of the last whole step) four a step, colour by streaming stores (the caller
// aligned dstColor + t to 16 bytes), depth and ID by ordinary ones (writeRowPixels); returns
// the column after them.
int writeVectors(const RowWrite& row, int t, bool* anyHole) {
    const RowWrite r = row;  // a copy in locals: the hole bytes' stores could alias `row`
    const __m128i tag = _mm_set1_epi32(r.tag);
    __m128i anyMissed = _mm_setzero_si128();
    alignas(16) int32_t at[4];
    for (; t + 4 <= r.w; t += 4) {
        const __m128i f = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r.from + t));
        const __m128i missed = _mm_cmplt_epi32(f, tag);
        anyMissed = _mm_or_si128(anyMissed, missed);
        const __m128i color = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r.landedColor + t));
        _mm_stream_si128(reinterpret_cast<__m128i*>(r.dstColor + t),
                         _mm_andnot_si128(missed, color));
        if (r.srcDepth) {
            // Column 0 where none landed, then zeroed.
            _mm_store_si128(reinterpret_cast<__m128i*>(at),
                            _mm_andnot_si128(missed, _mm_sub_epi32(f, tag)));
            auto gather = [&](const int32_t* src) {
                const __m128i v = _mm_set_epi32(src[at[3]], src[at[2]], src[at[1]], src[at[0]]);
                return _mm_andnot_si128(missed, v);
            };
            _mm_storeu_si128(reinterpret_cast<__m128i*>(r.dstDepth + t), gather(r.srcDepth));
            _mm_storeu_si128(reinterpret_cast<__m128i*>(r.dstId + t), gather(r.srcId));
        }
        const __m128i bytes = _mm_packs_epi16(_mm_packs_epi32(missed, missed), missed);
        const int holeWord = _mm_cvtsi128_si32(_mm_and_si128(bytes, _mm_set1_epi8(1)));
        std::memcpy(r.hole + t, &holeWord, 4);
    }
    *anyHole |= _mm_movemask_epi8(anyMissed) != 0;
    return t;
}
constexpr uintptr_t kStreamAlign = 16;
#endif

// One row's scatter with either offset form.
template <class Offset>
void scatterRow(const RowScatter& row, const Offset& offset, bool leftToRight) {
#if PLX_ROW_SSE2 || PLX_ROW_AVX2
    // Whole groups from the row's start on; the columns after the last one one by one, last
    // when walking left to right and first when walking right to left.
    const int groups = row.w / kLanes * kLanes;
    if (leftToRight) {
        landRange(row, offset, groups, row.w, true, landGroups(row, offset, groups, true, row.w));
    } else {
        landGroups(row, offset, groups, false, landRange(row, offset, groups, row.w, false, -1));
    }
#else
    landRange(row, offset, 0, row.w, leftToRight, leftToRight ? row.w : -1);
#endif
}

}  // namespace

void scatterDirectRow(const RowScatter& row, float a, float b, bool leftToRight) {
    scatterRow(row, DirectOffset{a, b}, leftToRight);
}

void scatterTableRow(const RowScatter& row, const OffsetTable& offsets, bool leftToRight) {
    scatterRow(row, TableOffset{offsets}, leftToRight);
}

bool writeRowPixels(const RowWrite& r) {
    bool anyHole = false;
    int t = 0;
#if PLX_ROW_SSE2 || PLX_ROW_AVX2
    // One by one up to the colour row's alignment, then vector steps. Colour alone is streamed:
    // streaming the depth and ID planes beside it made the row pass 6-7x slower (BM_Reproject
    // planes:1, one thread: AVX2 13.4-14.9 ms against 2.0-2.4 ms with ordinary stores, SSE2
    // 24.8 against 3.3-3.9 ms).
    auto aligned = [](const void* p) {
        return (reinterpret_cast<uintptr_t>(p) & (kStreamAlign - 1)) == 0;
    };
    for (; t < r.w && !aligned(r.dstColor + t); ++t) anyHole |= writeOne(r, t);
    t = writeVectors(r, t, &anyHole);
#endif
    for (; t < r.w; ++t) anyHole |= writeOne(r, t);
    return anyHole;
}

}  // namespace plx::stereo::detail::PLX_ISA_NS
