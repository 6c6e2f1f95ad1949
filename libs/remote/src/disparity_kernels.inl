// The q16 disparity codec's pixel loops, compiled once per ISA (plx_add_isa_kernels). Each row
// runs in stages the compiler vectorises at every tier: the codes of a row (independent per
// pixel), then its residuals (each from the codes before it); decoding rebuilds a row's codes
// (serial: each prediction needs the codes just decoded), then its floats. Written without
// branches in the vectorised loops: the build traps floating-point exceptions in its model
// (-ftrapping-math), so a comparison that picks a value must be a select the compiler can keep.
#include <algorithm>
#include <bit>
#include <limits>

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
// returns its first argument then).
void quantiseRow(const float* src, int w, double dmin, double inverseStep, uint16_t* q) {
    for (int x = 0; x < w; ++x) {
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

// The codes of one row from its residual bytes.
void reconstructRow(const uint8_t* low, const uint8_t* high, int w, int aboveFirst, uint16_t* q) {
    for (int x = 0; x < std::min(w, 2); ++x)
        q[x] = uint16_t(predict(q, x, aboveFirst) + unzigzag(uint16_t(low[x] | (high[x] << 8))));
    int b = w > 0 ? q[0] : 0, a = w > 1 ? q[1] : 0;
    for (int x = 2; x < w; ++x) {
        const int plane = std::clamp(2 * a - b, 0, 65535);
        const int prediction = ((a == 0) | (b == 0)) ? a : plane;
        const auto c = uint16_t(prediction + unzigzag(uint16_t(low[x] | (high[x] << 8))));
        q[x] = c;
        b = a;
        a = c;
    }
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

}  // namespace

// Non-negative floats order as their bit patterns do as integers, and the compiler vectorises
// integer min and max reductions where IEEE rules (NaN, signed zeros) forbid it the float ones.
// Less one, as unsigned, the pattern of +0 wraps to the largest value and a negative one (sign
// bit set) stays above every positive one, so the minimum is the smallest positive value's; the
// signed maximum from 0 ignores negatives. Non-NaN inputs only: a NaN's pattern lies above +inf.
PositiveRange positiveRange(const float* d, size_t n) {
    constexpr uint32_t kInfinityBits = 0x7f800000u;
    uint32_t loLessOne = 0xffffffffu;
    int32_t hi = 0;
    for (size_t i = 0; i < n; ++i) {
        loLessOne = std::min(loLessOne, std::bit_cast<uint32_t>(d[i]) - 1u);
        hi = std::max(hi, std::bit_cast<int32_t>(d[i]));
    }
    const float lo = loLessOne < kInfinityBits ? std::bit_cast<float>(loLessOne + 1u)
                                               : std::numeric_limits<float>::infinity();
    return {lo, std::bit_cast<float>(hi)};
}

void encodeQ16Planes(const float* disparity, int width, int height, double dmin, double step,
                     uint16_t* codes, uint8_t* planes) {
    const size_t n = size_t(width) * size_t(height);
    int aboveFirst = 0;
    for (int y = 0; y < height; ++y) {
        const size_t at = size_t(y) * size_t(width);
        quantiseRow(disparity + at, width, dmin, 1.0 / step, codes);
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

}  // namespace plx::remote::detail::PLX_ISA_NS
