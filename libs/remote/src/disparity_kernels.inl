// The q16 disparity codec's pixel loops, compiled once per ISA (plx_add_isa_kernels). Each row
// runs in stages the compiler vectorises at every tier: the codes of a row (independent per
// pixel), then its residuals (each from the codes before it); decoding rebuilds a row's codes
// (serial: each prediction needs the codes just decoded), then its floats. q16-packed adds a
// stage on each side, a row's residuals to and from two-bit symbols and escapes, in L1 between
// the residuals and zstd. Written without branches in the vectorised loops: the build traps
// floating-point exceptions in its model (-ftrapping-math), so a comparison that picks a value
// must be a select the compiler can keep.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstring>
#include <limits>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "disparity_kernels.h"
#include "disparity_q16_codes.h"

namespace plx::remote::detail::PLX_ISA_NS {
namespace {

using q16::kSteps;
using q16::predict;
using q16::unzigzag;
using q16::zigzag;

// The codes of one row: 0 for an empty pixel, else 1 + round((d - dmin) / step) with halves
// rounded up (docs/remote-protocol.md), clamped to 1..65535; the quotient is taken as a product
// with 1 / step (a division costs several times more in vector code; the two differ by an ulp of
// a double, which moves a code only where the quotient lies that close to a half). Clamping the
// quotient + 1/2 to [1/2, 65534 + 1/2] before truncating gives what clamping the code after does
// (truncation is monotone and the bounds truncate to 0 and 65534). A NaN takes code 1 (std::max
// returns its first argument then). An inverse step of 0 gives every drawn pixel code 1, as the
// format asks of a view with one value (or none) drawn.
void quantiseRow(const float* src, int w, double dmin, double inverseStep, uint16_t* q) {
    int x = 0;
#if defined(__AVX2__)
    // The same double arithmetic eight pixels at a time, written out: the compiler's version of
    // the loop below shuffled lanes between its conversions (three times the instructions). Max
    // returns its second operand for a NaN, as std::max(0.5, NaN) returns 0.5.
    const __m256d minus = _mm256_set1_pd(dmin), scale = _mm256_set1_pd(inverseStep);
    const __m256d half = _mm256_set1_pd(0.5), top = _mm256_set1_pd(kSteps + 0.5);
    const auto truncatedHalfUp = [&](__m128 d) {
        const __m256d t =
            _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_cvtps_pd(d), minus), scale), half);
        return _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(t, half), top));
    };
    for (; x + 8 <= w; x += 8) {
        const __m256 d = _mm256_loadu_ps(src + x);
        const __m256i truncated = _mm256_set_m128i(truncatedHalfUp(_mm256_extractf128_ps(d, 1)),
                                                   truncatedHalfUp(_mm256_castps256_ps128(d)));
        const __m256i drawn = _mm256_castps_si256(
            _mm256_cmp_ps(d, _mm256_setzero_ps(), _CMP_NEQ_UQ));  // NaN counts as drawn
        const __m256i codes =
            _mm256_and_si256(_mm256_add_epi32(truncated, _mm256_set1_epi32(1)), drawn);
        _mm_storeu_si128(
            reinterpret_cast<__m128i*>(q + x),
            _mm_packus_epi32(_mm256_castsi256_si128(codes), _mm256_extracti128_si256(codes, 1)));
    }
#endif
    for (; x < w; ++x) {
        const double halfUp = (double(src[x]) - dmin) * inverseStep + 0.5;
        const double clamped = std::min(std::max(0.5, halfUp), kSteps + 0.5);
        const int code = 1 + int(clamped);
        q[x] = uint16_t(src[x] != 0.0f ? code : 0);
    }
}

// The zigzagged residuals of one row's codes against predict(), split into low and high bytes.
void residualRow(const uint16_t* q, int w, int aboveFirst, uint8_t* low, uint8_t* high) {
    for (int x = 0; x < std::min(w, 2); ++x) {
        const uint16_t z = zigzag(int(q[x]) - predict(q, x, aboveFirst));
        low[x] = uint8_t(z);
        high[x] = uint8_t(z >> 8);
    }
    for (int x = 2; x < w; ++x) {
        const int a = q[x - 1], b = q[x - 2];
        const int plane = std::clamp(2 * a - b, 0, 65535);
        const int prediction = ((a == 0) | (b == 0)) ? a : plane;
        const uint16_t z = zigzag(int(q[x]) - prediction);
        low[x] = uint8_t(z);
        high[x] = uint8_t(z >> 8);
    }
}

// Codes x0 <= x < x1 of a row (x0 >= 2) from their residual bytes, one after the other: each
// prediction needs the two codes before it.
void reconstructSerial(const uint8_t* low, const uint8_t* high, int x0, int x1, uint16_t* q) {
    int b = q[x0 - 2], a = q[x0 - 1];
    for (int x = x0; x < x1; ++x) {
        const int plane = std::clamp(2 * a - b, 0, 65535);
        const int prediction = ((a == 0) | (b == 0)) ? a : plane;
        const auto c = uint16_t(prediction + unzigzag(uint16_t(low[x] | (high[x] << 8))));
        q[x] = c;
        b = a;
        a = c;
    }
}

#if defined(__AVX2__)
// Eight codes at a time by speculation. Where the predictor is the unclamped plane 2a - b at
// every pixel of a block, the codes follow q[i] = 2 q[i-1] - q[i-2] + r[i] (mod 2^16), whose
// solution is a closed form of two prefix sums of the residuals:
//   q[i] = a + (i + 1) (a - b) + sum_{k <= i} sum_{j <= k} r[j],
// a and b the two codes before the block. The block is computed so, then each pixel's condition
// is checked on the speculated codes (both neighbours drawn, 0 <= 2a - b <= 65535); by induction
// along the block, when all hold the speculated codes are the serial ones. A block where one
// fails (an empty pixel, the edge of the range; any byte of a hostile payload) is decoded
// serially instead, except a run of empty pixels (a = 0, residuals 0), which stays 0. With it the
// whole q16 decode of a 512-px cube4 set fell from 3.05 to 1.49 ms (BM_DisparityQ16).
int reconstructBlocks(const uint8_t* low, const uint8_t* high, int w, uint16_t* q) {
    const __m128i zero = _mm_setzero_si128();
    const __m128i one = _mm_set1_epi16(1);
    const __m128i iota1 = _mm_setr_epi16(1, 2, 3, 4, 5, 6, 7, 8);
    const __m128i lane7 = _mm_set1_epi16(0x0f0e);  // pshufb: broadcast 16-bit lane 7
    const __m128i lane6 = _mm_set1_epi16(0x0d0c);  // ... lane 6
    // The two codes before the block in lanes 6 (b) and 7 (a).
    __m128i before = _mm_insert_epi16(_mm_insert_epi16(zero, q[0], 6), q[1], 7);
    int x = 2;
    for (; x + 8 <= w; x += 8) {
        const __m128i bytes =
            _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(low + x)),
                              _mm_loadl_epi64(reinterpret_cast<const __m128i*>(high + x)));
        const __m128i r =
            _mm_xor_si128(_mm_srli_epi16(bytes, 1), _mm_sub_epi16(zero, _mm_and_si128(bytes, one)));
        __m128i sums = _mm_add_epi16(r, _mm_slli_si128(r, 2));  // sum_{j <= i} r[j]
        sums = _mm_add_epi16(sums, _mm_slli_si128(sums, 4));
        sums = _mm_add_epi16(sums, _mm_slli_si128(sums, 8));
        __m128i sums2 = _mm_add_epi16(sums, _mm_slli_si128(sums, 2));  // its prefix sums
        sums2 = _mm_add_epi16(sums2, _mm_slli_si128(sums2, 4));
        sums2 = _mm_add_epi16(sums2, _mm_slli_si128(sums2, 8));
        const __m128i a = _mm_shuffle_epi8(before, lane7);
        const __m128i slope = _mm_sub_epi16(a, _mm_shuffle_epi8(before, lane6));
        const __m128i codes = _mm_add_epi16(_mm_add_epi16(a, _mm_mullo_epi16(slope, iota1)), sums2);
        // Each pixel's two neighbours: the codes shifted by one and two lanes.
        const __m128i left = _mm_alignr_epi8(codes, before, 14);
        const __m128i left2 = _mm_alignr_epi8(codes, before, 12);
        // Unsigned: 2a - b >= 0 iff (b - a)+ <= a; 2a - b <= 65535 iff (a - b)+ <= 65535 - a.
        const __m128i below = _mm_subs_epu16(_mm_subs_epu16(left2, left), left);
        const __m128i above =
            _mm_subs_epu16(_mm_subs_epu16(left, left2), _mm_xor_si128(left, _mm_set1_epi16(-1)));
        const __m128i fails = _mm_or_si128(
            _mm_or_si128(_mm_cmpeq_epi16(left, zero), _mm_cmpeq_epi16(left2, zero)),
            _mm_xor_si128(_mm_cmpeq_epi16(_mm_or_si128(below, above), zero), _mm_set1_epi16(-1)));
        if (_mm_testz_si128(fails, fails)) {
            _mm_storeu_si128(reinterpret_cast<__m128i*>(q + x), codes);
            before = codes;
        } else if (_mm_extract_epi16(before, 7) == 0 && _mm_testz_si128(r, r)) {
            _mm_storeu_si128(reinterpret_cast<__m128i*>(q + x), zero);
            before = zero;
        } else {
            reconstructSerial(low, high, x, x + 8, q);
            before = _mm_loadu_si128(reinterpret_cast<const __m128i*>(q + x));
        }
    }
    return x;
}
#endif

// The codes of one row from its residual bytes.
void reconstructRow(const uint8_t* low, const uint8_t* high, int w, int aboveFirst, uint16_t* q) {
    for (int x = 0; x < std::min(w, 2); ++x)
        q[x] = uint16_t(predict(q, x, aboveFirst) + unzigzag(uint16_t(low[x] | (high[x] << 8))));
    int x = std::min(w, 2);
#if defined(__AVX2__)
    if (w > 2) x = reconstructBlocks(low, high, w, q);
#endif
    if (x < w) reconstructSerial(low, high, x, w, q);
}

// The disparities of one row's codes, each clamped to the row's exact range [lo, hi] so that the
// warp's row clipping stays true.
void dequantiseRow(const uint16_t* q, int w, double dmin, double step, float lo, float hi,
                   float* dst) {
    for (int x = 0; x < w; ++x) {
        const int c = q[x];
        const auto v = float(dmin + double(c - 1) * step);
        const float clamped = v < lo ? lo : (hi < v ? hi : v);
        dst[x] = c == 0 ? 0.0f : clamped;
    }
}

// q16-packed: one row's zigzag residuals (low and high bytes) as two-bit symbols min(z, 3), four
// pixels a byte from bit 0, and the escapes (z >= 3, two bytes each) appended at `escapes`.
// Returns the escapes written.
size_t packRow(const uint8_t* low, const uint8_t* high, int w, uint8_t* symbols, uint8_t* escapes) {
    size_t count = 0;
    int x = 0;
#if defined(__AVX2__)
    const __m256i three = _mm256_set1_epi8(3);
    for (; x + 32 <= w; x += 32) {
        const __m256i lo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(low + x));
        const __m256i hi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(high + x));
        const __m256i highSet = _mm256_andnot_si256(_mm256_cmpeq_epi8(hi, _mm256_setzero_si256()),
                                                    three);  // 3 where z >= 256
        const __m256i sym = _mm256_or_si256(_mm256_min_epu8(lo, three), highSet);
        // Four symbols to a byte: s0 + 4 s1 per 16-bit lane, then p0 + 16 p1 per 32-bit lane.
        const __m256i pairs = _mm256_maddubs_epi16(sym, _mm256_set1_epi16(0x0401));
        const __m256i quads = _mm256_madd_epi16(pairs, _mm256_set1_epi32(0x00100001));
        const __m256i bytes =
            _mm256_packus_epi16(_mm256_packus_epi32(quads, quads), _mm256_setzero_si256());
        const auto first = uint32_t(_mm256_cvtsi256_si32(bytes));
        const auto second = uint32_t(_mm256_extract_epi32(bytes, 4));
        std::memcpy(symbols + x / 4, &first, 4);
        std::memcpy(symbols + x / 4 + 4, &second, 4);
        for (auto m = uint32_t(_mm256_movemask_epi8(_mm256_cmpeq_epi8(sym, three))); m != 0;
             m &= m - 1) {
            const int i = x + std::countr_zero(m);
            escapes[2 * count] = low[i];
            escapes[2 * count + 1] = high[i];
            ++count;
        }
    }
#endif
    for (; x < w; x += 4) {
        unsigned byte = 0;
        for (int k = 0; k < 4 && x + k < w; ++k) {
            const int i = x + k;
            const bool escape = high[i] != 0 || low[i] >= 3;
            byte |= unsigned(escape ? 3 : low[i]) << (2 * k);
            if (escape) {
                escapes[2 * count] = low[i];
                escapes[2 * count + 1] = high[i];
                ++count;
            }
        }
        symbols[x / 4] = uint8_t(byte);
    }
    return count;
}

// The reverse: a row's residual bytes from its symbols and the escapes from `escapes` on, at most
// `left` of them. Returns the escapes used, or -1 when the row needs more.
ptrdiff_t unpackRow(const uint8_t* symbols, int w, const uint8_t* escapes, size_t left,
                    uint8_t* low, uint8_t* high) {
    size_t used = 0;
    int x = 0;
#if defined(__AVX2__)
    const __m256i three = _mm256_set1_epi8(3);
    // Byte k of a 128-bit lane takes symbol byte k / 4 (of the lane's four), masked to its field
    // (bits 2 (k mod 4)); fields 2 and 3 shifted down a nibble; a table maps s << 0 or s << 2 to s.
    const __m256i spread = _mm256_setr_epi8(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4,
                                            4, 5, 5, 5, 5, 6, 6, 6, 6, 7, 7, 7, 7);
    const __m256i fields = _mm256_set1_epi32(int32_t(0xc0300c03u));
    const __m256i table = _mm256_setr_epi8(0, 1, 2, 3, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 0, 1, 2,
                                           3, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0);
    for (; x + 32 <= w; x += 32) {
        const __m128i eight = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(symbols + x / 4));
        const __m256i t = _mm256_and_si256(
            _mm256_shuffle_epi8(_mm256_broadcastsi128_si256(eight), spread), fields);
        const __m256i nibbles = _mm256_or_si256(
            _mm256_and_si256(t, _mm256_set1_epi32(0x00000f0f)),
            _mm256_and_si256(_mm256_srli_epi16(t, 4), _mm256_set1_epi32(0x0f0f0000)));
        const __m256i sym = _mm256_shuffle_epi8(table, nibbles);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(low + x), sym);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(high + x), _mm256_setzero_si256());
        for (auto m = uint32_t(_mm256_movemask_epi8(_mm256_cmpeq_epi8(sym, three))); m != 0;
             m &= m - 1) {
            if (used == left) return -1;
            const int i = x + std::countr_zero(m);
            low[i] = escapes[2 * used];
            high[i] = escapes[2 * used + 1];
            ++used;
        }
    }
#endif
    // x is a multiple of 4 here: a whole symbol byte at a time, its four pixels in one store
    // where none of them is an escape (b & b >> 1 has a bit 2k set for each symbol 3).
    std::memset(high + x, 0, size_t(w - x));
    for (; x < w; x += 4) {
        const unsigned b = symbols[x / 4];
        if (x + 4 <= w && (b & (b >> 1) & 0x55u) == 0) {
            const uint8_t four[4] = {uint8_t(b & 3u), uint8_t(b >> 2 & 3u), uint8_t(b >> 4 & 3u),
                                     uint8_t(b >> 6)};
            std::memcpy(low + x, four, 4);
            continue;
        }
        for (int i = x; i < std::min(x + 4, w); ++i) {
            const int sym = int(b >> (2 * (i - x)) & 3u);
            low[i] = uint8_t(sym);
            if (sym == 3) {
                if (used == left) return -1;
                low[i] = escapes[2 * used];
                high[i] = escapes[2 * used + 1];
                ++used;
            }
        }
    }
    return ptrdiff_t(used);
}

// Non-negative floats order as their bit patterns do as integers, and the compiler vectorises
// integer min and max reductions where IEEE rules (NaN, signed zeros) forbid it the float ones.
// Less one, as unsigned, the pattern of +0 wraps to the largest value and a negative one (sign
// bit set) stays above every positive one, so the minimum is the smallest positive value's; the
// signed maximum from 0 ignores negatives. Non-NaN inputs only: a NaN's pattern lies above +inf.
// The reductions start from these and end in rangeOf.
constexpr uint32_t kNoLoLessOne = 0xffffffffu;
constexpr int32_t kNoHi = 0;

PositiveRange rangeOf(uint32_t loLessOne, int32_t hi) {
    constexpr uint32_t kInfinityBits = 0x7f800000u;
    const float lo = loLessOne < kInfinityBits ? std::bit_cast<float>(loLessOne + 1u)
                                               : std::numeric_limits<float>::infinity();
    return {lo, std::bit_cast<float>(hi)};
}

}  // namespace

PositiveRange positiveRange(const float* d, size_t n) {
    uint32_t loLessOne = kNoLoLessOne;
    int32_t hi = kNoHi;
    for (size_t i = 0; i < n; ++i) {
        loLessOne = std::min(loLessOne, std::bit_cast<uint32_t>(d[i]) - 1u);
        hi = std::max(hi, std::bit_cast<int32_t>(d[i]));
    }
    return rangeOf(loLessOne, hi);
}

PositiveRange positiveRangeInRows(const float* d, int width, int height, const float* rowMin,
                                  const float* rowMax, int64_t* outside) {
    uint32_t loLessOne = kNoLoLessOne;
    int32_t hi = kNoHi;
    int64_t count = 0;
    for (int y = 0; y < height; ++y) {
        const float* row = d + size_t(y) * size_t(width);
        const float rowLo = rowMin[y], rowHi = rowMax[y];
        int rowOutside = 0;
        for (int x = 0; x < width; ++x) {
            loLessOne = std::min(loLessOne, std::bit_cast<uint32_t>(row[x]) - 1u);
            hi = std::max(hi, std::bit_cast<int32_t>(row[x]));
            rowOutside += int(!(row[x] >= rowLo) | !(row[x] <= rowHi));
        }
        count += rowOutside;
    }
    *outside = count;
    return rangeOf(loLessOne, hi);
}

void encodeQ16Planes(const float* disparity, int width, int height, double dmin, double inverseStep,
                     uint16_t* codes, uint8_t* planes) {
    const size_t n = size_t(width) * size_t(height);
    int aboveFirst = 0;
    for (int y = 0; y < height; ++y) {
        const size_t at = size_t(y) * size_t(width);
        quantiseRow(disparity + at, width, dmin, inverseStep, codes);
        residualRow(codes, width, aboveFirst, planes + at, planes + n + at);
        aboveFirst = width > 0 ? codes[0] : 0;
    }
}

void decodeQ16Planes(const uint8_t* planes, int width, int height, double dmin, double step,
                     const float* rowMin, const float* rowMax, uint16_t* codes, float* disparity) {
    const size_t n = size_t(width) * size_t(height);
    int aboveFirst = 0;
    for (int y = 0; y < height; ++y) {
        const size_t at = size_t(y) * size_t(width);
        reconstructRow(planes + at, planes + n + at, width, aboveFirst, codes);
        dequantiseRow(codes, width, dmin, step, rowMin[y], rowMax[y], disparity + at);
        aboveFirst = width > 0 ? codes[0] : 0;
    }
}

size_t encodeQ16Packed(const float* disparity, int width, int height, double dmin,
                       double inverseStep, uint16_t* codes, uint8_t* low, uint8_t* high,
                       uint8_t* symbols, uint8_t* escapes) {
    const size_t rowBytes = q16::packedRowBytes(width);
    size_t count = 0;
    int aboveFirst = 0;
    for (int y = 0; y < height; ++y) {
        quantiseRow(disparity + size_t(y) * size_t(width), width, dmin, inverseStep, codes);
        residualRow(codes, width, aboveFirst, low, high);
        count += packRow(low, high, width, symbols + size_t(y) * rowBytes, escapes + 2 * count);
        aboveFirst = width > 0 ? codes[0] : 0;
    }
    return count;
}

ptrdiff_t decodeQ16Packed(const uint8_t* symbols, const uint8_t* escapes, size_t escapeCount,
                          int width, int height, double dmin, double step, const float* rowMin,
                          const float* rowMax, uint16_t* codes, uint8_t* low, uint8_t* high,
                          float* disparity) {
    const size_t rowBytes = q16::packedRowBytes(width);
    size_t used = 0;
    int aboveFirst = 0;
    for (int y = 0; y < height; ++y) {
        const ptrdiff_t row = unpackRow(symbols + size_t(y) * rowBytes, width, escapes + 2 * used,
                                        escapeCount - used, low, high);
        if (row < 0) return -1;
        used += size_t(row);
        reconstructRow(low, high, width, aboveFirst, codes);
        dequantiseRow(codes, width, dmin, step, rowMin[y], rowMax[y],
                      disparity + size_t(y) * size_t(width));
        aboveFirst = width > 0 ? codes[0] : 0;
    }
    return ptrdiff_t(used);
}

}  // namespace plx::remote::detail::PLX_ISA_NS
