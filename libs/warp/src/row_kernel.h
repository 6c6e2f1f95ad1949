#pragma once
// The row transform shared by the dispatch code (warper.cpp) and its per-ISA kernel
// (warp_row.inl): source pixels of one row to destination splat rectangles and depth keys.

#include <cstdint>

#include <plx/core/cpu.h>
#include <plx/core/image.h>
#include <plx/warp/equation.h>

namespace plx::warp::detail {

// Splat rectangle half-sizes per kind; kDerivative computes them per pixel.
enum class RowSplat : int { kDerivative = 0, kPoint = 1, kFixed2x2 = 2 };

struct RowInput {
    WarpCoefficients w;
    int y = 0;
    int width = 0;                     // source row length (neighbours exist inside it)
    int x0 = 0, x1 = 0;                // the pixels to transform, [x0, x1)
    const float* disparity = nullptr;  // the row, width values
    const float* above = nullptr;      // the row above, or null (first row)
    const float* below = nullptr;      // the row below, or null (last row)
    RowSplat splat = RowSplat::kDerivative;
    float destWidth = 0, destHeight = 0;
    float maxSplat = 6.0f;  // kMaxSplatSize
};

// Per transformed pixel i (source x = x0 + i): the destination rectangle [rx0, rx1) x [ry0, ry1),
// clipped to the destination, empty (rx0 == rx1) where the point is not in front of it; key =
// float bits of the destination 1/w, plus one (so 0 never marks a written pixel).
struct RowOutput {
    int32_t* rx0;
    int32_t* rx1;
    int32_t* ry0;
    int32_t* ry1;
    uint32_t* key;
};

// The destination rows [y0, y1) that a transformed row's non-empty splats reach (destHeight and
// 0 when none does).
struct RowReach {
    int32_t y0;
    int32_t y1;
};

PLX_ISA_DECLARE(RowReach transformRow(const RowInput& in, const RowOutput& out))

inline auto activeTransformRow() {
    return PLX_ISA_PICK_UP_TO_AVX2(transformRow);
}

// One transformed row's splats written into a band of the destination words (splat_row.inl):
// each word becomes the max of itself and (key << 32 | colour) inside the splat's rectangle
// clipped to rows [bandY0, bandY1). The caller must be the band's only writer (the vector path
// rewrites the words of a rectangle's aligned 4-word blocks outside it with their own values).
struct SplatRowInput {
    const int32_t* rx0;  // the row's transformed pixels (RowOutput), `count` of them
    const int32_t* rx1;
    const int32_t* ry0;
    const int32_t* ry1;
    const uint32_t* key;
    const float* disparity;  // the source row's pixels from the span's first
    const Rgba8* color;
    int count = 0;
    uint32_t clearBits = 0;     // what delta = 0 pixels write
    uint64_t* words = nullptr;  // 32-byte aligned; rows `stride` words apart, stride % 4 == 0
    size_t stride = 0;
    int bandY0 = 0, bandY1 = 0;
};

PLX_ISA_DECLARE(void splatRow(const SplatRowInput& in))

// Unpacks `width` destination words (unpack_row.inl) into colour (the clear colour where no
// splat wrote), 1/w (0 there) and the hole mask (1 there, else 0), zeroes the words, and returns
// the row's holes.
PLX_ISA_DECLARE(int unpackRow(uint64_t* words, int width, uint32_t clearBits, Rgba8* color,
                              float* depth, uint8_t* holeMask))

inline auto activeUnpackRow() {
    return PLX_ISA_PICK_UP_TO_AVX2(unpackRow);
}

// The smallest and largest ordered key (a float's bits made an integer that orders as the float
// does; reference.cpp) of a row of `width` floats without NaN (row_range.inl).
struct KeyRange {
    int32_t lo;
    int32_t hi;
};

PLX_ISA_DECLARE(KeyRange rowKeyRange(const float* row, int width))

inline auto activeRowKeyRange() {
    return PLX_ISA_PICK_UP_TO_AVX2(rowKeyRange);
}

inline auto activeSplatRow() {
    return PLX_ISA_PICK_UP_TO_AVX2(splatRow);
}

}  // namespace plx::warp::detail
