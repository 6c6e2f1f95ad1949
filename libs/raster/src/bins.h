#pragma once
// The binning stage's output, which the tile kernel (tile_raster.inl) walks, and the kernels
// the tiled renderer (renderer.cpp) dispatches per ISA: chosen once per frame (RasterKernels),
// called once per tile or per block of vertices, never per triangle.

#include <cstdint>
#include <vector>

#include "pipeline.h"

namespace plx::raster::detail {

// Bin entries with this bit refer to a chunk's materialised triangles (clipped or subset).
constexpr uint32_t kMaterialisedBit = 0x80000000u;

// A binned triangle carries its snapped vertices, so the tile stage streams
// through its bins instead of gathering vertices from scattered memory (measured: gathering
// made random-order scenes 3x slower). Barycentric weights of clipped or subset triangles stay
// in the chunk's `materialised` list.
struct BinnedTri {
    int32_t x[3], y[3];
    float invW[3];
    uint32_t ref;  // mesh-local triangle index, or kMaterialisedBit | index into materialised
};

struct Materialised {
    uint32_t mesh;
    uint32_t localTri;
    Vec3 bary[3];
    // Flat shading's colour, taken once here rather than once per tile the triangle reaches
    // (large triangles of a subset, such as a second stereo eye's, reach several).
    Rgba8 flatColor;
};

// A triangle that covers no sample centre: its centre pixel and nearest 1/w, tested against the
// final depth after the tiles are done.
struct Unsampled {
    uint32_t globalTri;
    int32_t x, y;
    float maxInvW;
};

struct Chunk {
    // Full render: mesh-local triangle range of one mesh. Subset: a range of the subset list.
    size_t mesh = 0;
    size_t begin = 0, end = 0;
    std::vector<Materialised> materialised;
    std::vector<std::vector<BinnedTri>> bins;  // per tile
    std::vector<Unsampled> unsampled;
    uint64_t clipped = 0, binned = 0;

    void reset(size_t tiles) {
        materialised.clear();
        unsampled.clear();
        if (bins.size() != tiles) bins.resize(tiles);
        for (auto& b : bins) b.clear();
        clipped = binned = 0;
    }
};

// One tile's work for drawTile.
struct TileJob {
    const scene::Scene* scene = nullptr;
    const Viewport* vp = nullptr;
    const ShadeContext* ctx = nullptr;
    const Chunk* chunks = nullptr;  // the frame's chunks, in submission order
    size_t chunkCount = 0;
    size_t tile = 0;                // index into each chunk's bins
    int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // the tile's pixels, inclusive
    RenderTargets rt;               // the frame's targets, or tile memory standing in for them
    // Clear the tile's pixels of `rt` first (colour to clearWord; depth and IDs unless
    // colorOnly; the second layer when present). Tile memory arrives cleared.
    bool clear = false;
    uint32_t clearWord = 0;
    // Coarse occlusion culling with these blocks (reset for the tile by the caller); null: none.
    DepthBlocks* occlusion = nullptr;
};

PLX_ISA_DECLARE(
    // Clears (when asked) and draws one tile: every binned triangle of it, in submission order.
    // Returns the triangle-tile pairs skipped by coarse occlusion culling.
    uint64_t drawTile(const TileJob& job);
    // Streams the rectangle [x0, x1] x [y0, y1] of tile memory `tile` to `frame` and puts the
    // clear values (depth and IDs 0, colour `colorWord`) back into it; a plane the frame lacks
    // is only cleared.
    void resolveTileMemory(const RenderTargets& tile, const RenderTargets& frame, int x0, int y0,
                           int x1, int y1, uint32_t colorWord))

// The kernels of the active ISA path (plx/core/cpu.h), taken once per frame.
struct RasterKernels {
    decltype(&isa_scalar::drawTile) drawTile;
    decltype(&isa_scalar::resolveTileMemory) resolveTileMemory;
    decltype(&isa_scalar::transformPositions) transformPositions;

    // The 8-wide loops are AVX2 code, and the avx512 path takes their avx2 copies: compiled for
    // x86-64-v4 the same source was no faster (docs/raster-performance.md, tried and dropped).
    static RasterKernels active() {
        return {PLX_ISA_PICK_UP_TO_AVX2(drawTile), PLX_ISA_PICK_UP_TO_AVX2(resolveTileMemory),
                PLX_ISA_PICK_UP_TO_AVX2(transformPositions)};
    }
};

}  // namespace plx::raster::detail
