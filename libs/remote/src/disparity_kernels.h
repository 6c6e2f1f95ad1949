#pragma once
// Private: the per-ISA entry points of the q16 disparity codec's pixel loops
// (disparity_kernels.inl), compiled once per ISA by plx_add_isa_kernels and picked per view with
// PLX_ISA_PICK (<plx/core/cpu.h>). Arguments are plain pointers into caller-owned buffers; images
// are contiguous rows of `width` values. Every tier computes the same values (the build keeps
// fp-contract off), which the white-box tests check against disparity_q16_reference.cpp.
#include <cstddef>
#include <cstdint>

#include <plx/core/cpu.h>

namespace plx::remote::detail {

// The smallest positive and the largest of n non-NaN disparities (lo = +inf when none is
// positive; hi >= 0).
struct PositiveRange {
    float lo = 0.0f;
    float hi = 0.0f;
};

// encode: the codes of every row (docs/remote-protocol.md, "Disparity, q16"; inverseStep is
// 1 / step, or 0 where the range has no step) and their zigzagged residuals, low bytes in
// planes[0, w h), high bytes in planes[w h, 2 w h). `codes` holds one row.
// decode: the reverse, each drawn pixel clamped to its row's [rowMin, rowMax].
PLX_ISA_DECLARE(PositiveRange positiveRange(const float* d, size_t n));
// positiveRange of a width x height image and, in the same pass, the count of pixels outside
// their row's [rowMin[y], rowMax[y]] (NaN counts as outside; the range is then meaningless).
PLX_ISA_DECLARE(PositiveRange positiveRangeInRows(const float* d, int width, int height,
                                                  const float* rowMin, const float* rowMax,
                                                  int64_t* outside));
PLX_ISA_DECLARE(void encodeQ16Planes(const float* disparity, int width, int height, double dmin,
                                     double inverseStep, uint16_t* codes, uint8_t* planes));
PLX_ISA_DECLARE(void decodeQ16Planes(const uint8_t* planes, int width, int height, double dmin,
                                     double step, const float* rowMin, const float* rowMax,
                                     uint16_t* codes, float* disparity));

// q16-packed (docs/remote-protocol.md, "Disparity, q16-packed"): the same codes and residuals,
// each row's zigzag values as two-bit symbols (ceil(width / 4) bytes a row) and escapes (u16
// little-endian, 2 bytes each). `low` and `high` are row scratch of width bytes.
// encode: returns the escapes written; `escapes` holds 2 width height bytes.
// decode: returns the escapes used, or -1 when a row needs more than escapeCount holds (the
// rows before it are decoded); each drawn pixel clamped to its row's [rowMin, rowMax].
PLX_ISA_DECLARE(size_t encodeQ16Packed(const float* disparity, int width, int height, double dmin,
                                       double inverseStep, uint16_t* codes, uint8_t* low,
                                       uint8_t* high, uint8_t* symbols, uint8_t* escapes));
PLX_ISA_DECLARE(ptrdiff_t decodeQ16Packed(const uint8_t* symbols, const uint8_t* escapes,
                                          size_t escapeCount, int width, int height, double dmin,
                                          double step, const float* rowMin, const float* rowMax,
                                          uint16_t* codes, uint8_t* low, uint8_t* high,
                                          float* disparity));

}  // namespace plx::remote::detail
