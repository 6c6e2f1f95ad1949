#pragma once
// The reprojection's row kernels (reproject.cpp), compiled once per ISA (row_pass.inl,
// plx_add_isa_kernels ... ISAS avx2): the scatter of one first-eye row into its landings, by the
// direct form or the offset table, and one second-eye row written from them. Plain data only here:
// the kernels are compiled under several ISAs' flags, so nothing they share may be an inline
// function.

#include <cstdint>

#include <plx/core/cpu.h>
#include <plx/core/image.h>

namespace plx::stereo::detail {

// Beyond the paper: first-eye columns xA and xB, neighbours in the row, landed at slots tA and tB
// inside the row, at least two apart in the columns' order. The surface they sample is spread
// apart between them, and a pixel landing there from elsewhere may lie behind it: reproject.cpp
// takes off, after the row's scatter, each landing between them that lies farther than the
// nearer of the two, and beyond a wide gap's ends those the surface may still cover
// (reproject.h, gaps).
struct RowGap {
    int32_t tA, tB, xA, xB;
};

// One row's scatter: its first-eye depth and colour in, its landings (w + 1 slots each, the last
// the spare slot that takes every landing outside the row) and gaps out. A landing stores tag +
// its first-eye column in from[] and that column's colour in color[]; a gap is appended to
// gaps[0 .. *gapCount) (room for w).
struct RowScatter {
    const float* srcDepth;
    const Rgba8* srcColor;
    int w;
    int32_t tag;
    int32_t* from;
    Rgba8* color;
    // The first eye's ID row, read ahead where the shift changes (holes open there, and marking
    // a colour-only second eye's hole runs reads the IDs beside them); or null.
    const uint32_t* readAheadId = nullptr;
    RowGap* gaps = nullptr;
    int* gapCount = nullptr;
};

// One second-eye row written from its landings: slot t landed when from[t] >= tag, from
// first-eye column from[t] - tag. Colour (the landed colour, 0 where none landed) and the hole
// byte (1 where none landed) at every pixel; with planes (srcDepth non-null), depth and ID from
// the landing's first-eye column, 0 where none landed.
struct RowWrite {
    const int32_t* from;
    const Rgba8* landedColor;
    int32_t tag;
    int w;
    Rgba8* dstColor;
    uint8_t* hole;
    // Planes, all four null for a colour-only second eye. Depth is moved as its bits.
    const int32_t* srcDepth = nullptr;
    const int32_t* srcId = nullptr;
    int32_t* dstDepth = nullptr;
    int32_t* dstId = nullptr;
};

// The offset table's entries as OffsetLut holds them (reproject.h): a pixel of 1/w v lands at
// its column + table[q], q = v scale + 0.5 clamped to [0, last] (NaN to 0), truncated.
struct OffsetTable {
    const float* table;
    float scale;
    float last;
};

PLX_ISA_DECLARE(
    // The direct form's scatter (offset a (1/w) + b, b including the pixel centre), in
    // occlusion-compatible order: left to right when leftToRight, else right to left.
    void scatterDirectRow(const RowScatter& row, float a, float b, bool leftToRight);
    // The same with the offsets from the table (Fu section 2).
    void scatterTableRow(const RowScatter& row, const OffsetTable& offsets, bool leftToRight);
    // Writes the row; returns whether a pixel of it is a hole. Colour by streaming stores: the
    // caller fences before the row is read on another thread.
    bool writeRowPixels(const RowWrite& row))

}  // namespace plx::stereo::detail
