#pragma once
// Shared between the warp's parts: the row plan (warper.cpp), the z-buffer pass (zbuffer.cpp),
// the occlusion-compatible pass (occlusion.cpp) and the mesh kernel (mesh.cpp).

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstring>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include <plx/core/parallel.h>
#include <plx/warp/warp.h>

#include "row_kernel.h"

namespace plx::warp::detail {

struct ViewJob {
    const ReferenceView* view;
    WarpCoefficients w;
    float depthScale = 1.0f;  // its set's compositing factor on the destination 1/w (holes.h)
};

// One source row of one view and its potentially visible span [x0, x1). Mesh: the quads between
// rows y and y + 1 whose left pixel is in the span.
struct RowJob {
    uint32_t view;
    int32_t y;
    int32_t x0, x1;
    int32_t destY0, destY1;  // the destination rows its splats can reach (RowSpan)
    uint32_t offset;         // where its pixels' transforms start in the Transformed arrays
};

// Transformed entries a row job takes: one per pixel, or (mesh) both rows' vertices, the span
// plus the pixel right of it.
inline size_t transformedSize(const RowJob& row, bool mesh) {
    return mesh ? 2 * size_t(row.x1 - row.x0 + 1) : size_t(row.x1 - row.x0);
}

// A mesh vertex: a source pixel's warp, its own disparity (for the tear test) and colour bits.
struct MeshVertex {
    WarpedPoint p;
    float sourceDelta;
    uint32_t color;
};

// The row transform's output for every planned row (RowJob::offset), kept between frames.
// Mesh rows hold their two source rows' warped vertices instead (meshVertexCount each).
struct Transformed {
    std::vector<MeshVertex> vertices;
    std::vector<int32_t> rx0, rx1, ry0, ry1;
    std::vector<uint32_t> key;
    // Per row job: the destination rows its transformed splats really reach, [first, second)
    // (tighter than RowJob's clip bound, which spans the row's whole disparity range).
    std::vector<std::pair<int32_t, int32_t>> rowReach;
    void reserve(size_t n) {
        if (key.size() >= n) return;
        rx0.resize(n);
        rx1.resize(n);
        ry0.resize(n);
        ry1.resize(n);
        key.resize(n);
    }
    RowOutput at(size_t offset) {
        return {rx0.data() + offset, rx1.data() + offset, ry0.data() + offset, ry1.data() + offset,
                key.data() + offset};
    }
};

// The destination words (key << 32 | colour bits; 0 = nothing written) and the colour that
// background (delta = 0) pixels write.
struct DestBuffer {
    uint64_t* words;  // 32-byte aligned
    int width, height;
    uint32_t clearBits;
    size_t stride;  // words per row: width rounded up to 4, so 4-word blocks never span rows
};

inline uint32_t rgbaBits(Rgba8 c) {
    return std::bit_cast<uint32_t>(c);
}

Status checkWarpInputs(std::span<const ReferenceSet* const> sets, const Camera& destination);

// Coefficients per view and the clipped rows of all views, in set, view and row order.
void planRows(std::span<const ReferenceSet* const> sets, const Camera& destination,
              const WarpOptions& options, std::vector<ViewJob>* views, std::vector<RowJob>* rows,
              WarpStats* stats);

// Transforms one row job with the active row kernel into its place in `out` (not for mesh) and
// returns the destination rows its splats reach ([first, second), empty when none).
std::pair<int32_t, int32_t> transformRowJob(const ViewJob& view, const RowJob& row, Splat splat,
                                            const DestBuffer& dest, Transformed* out);

// The z-buffer pass over all rows, in parallel destination bands; finish(y0, y1) runs on each
// band's rows as soon as they are complete (the unpack, by the thread that warped them).
void warpZBuffer(ThreadPool& pool, const std::vector<ViewJob>& views,
                 const std::vector<RowJob>& rows, const WarpOptions& options,
                 const DestBuffer& dest, Transformed* transformed,
                 const std::function<void(int, int)>& finish);

// McMillan's occlusion-compatible order, one thread: each view painted toward (positive
// epipole) or away from (negative) its epipole; `stamp` marks which view wrote each pixel so
// that a view overwrites its own pixels and z-tests against other views'.
void warpOcclusionCompatible(const std::vector<ViewJob>& views, const std::vector<RowJob>& rows,
                             const Camera& destination, const WarpOptions& options,
                             const DestBuffer& dest, uint8_t* stamp, Transformed* transformed);

// How a splat writes a destination word: z-buffer max (one thread, or several with a
// compare-and-swap), or the occlusion-compatible painter (overwrites what the same view wrote,
// z-tests against other views).
enum class WriteMode { kMax, kAtomicMax, kPainter };
struct Writer {
    DestBuffer dest;
    WriteMode mode = WriteMode::kMax;
    int bandY0 = 0, bandY1 = 0;  // the destination rows this writer may write, [bandY0, bandY1)
    uint8_t* stamp = nullptr;    // kPainter: per destination pixel, the view that wrote it + 1
    uint8_t viewStamp = 0;
};

template <WriteMode kMode>
inline void writeWord(const Writer& w, size_t i, uint64_t v) {
    uint64_t* p = w.dest.words + i;
    if constexpr (kMode == WriteMode::kAtomicMax) {
        // The packed word makes the z-test and write one compare-and-swap, retried only while
        // the word is still larger: the result is the maximum whatever the interleaving.
        std::atomic_ref<uint64_t> ref(*p);
        uint64_t old = ref.load(std::memory_order_relaxed);
        while (v > old && !ref.compare_exchange_weak(old, v, std::memory_order_relaxed)) {
        }
    } else if constexpr (kMode == WriteMode::kMax) {
        // Always stores (a conditional move): neighbouring splats overlap with close depths, so
        // a branch on the test would mispredict about half the time.
        const uint64_t old = *p;
        *p = v > old ? v : old;
    } else {
        if (w.stamp[i] == w.viewStamp || v > *p) {
            *p = v;
            w.stamp[i] = w.viewStamp;
        }
    }
}

// Splats transformed pixel i with the given colour bits.
template <WriteMode kMode>
inline void splatPixel(const Writer& w, const Transformed& s, size_t i, uint32_t color) {
    const int32_t x0 = s.rx0[i], x1 = s.rx1[i];
    const int32_t y0 = std::max(s.ry0[i], w.bandY0), y1 = std::min(s.ry1[i], w.bandY1);
    const uint64_t v = uint64_t(s.key[i]) << 32 | color;
    for (int32_t y = y0; y < y1; ++y) {
        const size_t base = size_t(y) * w.dest.stride;
        for (int32_t x = x0; x < x1; ++x) writeWord<kMode>(w, base + size_t(x), v);
    }
}

// The colour bits a source pixel writes: its own, or the clear colour where delta = 0.
inline uint32_t sourceColor(const ReferenceView& view, int x, int y, float delta,
                            uint32_t clearBits) {
    return delta > 0.0f ? rgbaBits(view.color.row(y)[x]) : clearBits;
}

// Warps the vertices of one mesh row job (both source rows, mesh.cpp) into `out` at its offset
// and returns the destination rows its triangles can reach ([first, second), empty when none).
std::pair<int32_t, int32_t> transformMeshRow(const ViewJob& view, const RowJob& row,
                                             const DestBuffer& dest, Transformed* out);

// Draws the mesh quads of one transformed row job (mesh.cpp). `order`: the quads' x in drawing
// order, or empty for x0 .. x1 - 1 ascending.
void meshRow(const ViewJob& view, const RowJob& row, const Writer& writer, const Transformed& t,
             std::span<const int32_t> order = {});

}  // namespace plx::warp::detail
