// The z-buffer pass (Mark, Bishop, McMillan, "Speedup techniques": "our current parallel
// implementation instead uses a z-buffer to resolve visibility"): the clipped rows of every view
// in chunks of about equal source pixel counts, run by the warper's threads.

#include <algorithm>

#include <plx/warp/splat.h>

#include "warp_internal.h"

namespace plx::warp::detail {

void transformRowJob(const ViewJob& view, const RowJob& row, Splat splat, const DestBuffer& dest,
                     RowScratch* scratch) {
    const ReferenceView& v = *view.view;
    const int h = v.disparity.height();
    RowInput in;
    in.w = view.w;
    in.y = row.y;
    in.width = v.disparity.width();
    in.x0 = row.x0;
    in.x1 = row.x1;
    in.disparity = v.disparity.row(row.y);
    in.above = row.y > 0 ? v.disparity.row(row.y - 1) : nullptr;
    in.below = row.y + 1 < h ? v.disparity.row(row.y + 1) : nullptr;
    in.splat = splat == Splat::kPoint       ? RowSplat::kPoint
               : splat == Splat::kFixed2x2 ? RowSplat::kFixed2x2
                                           : RowSplat::kDerivative;
    in.destWidth = float(dest.width);
    in.destHeight = float(dest.height);
    in.maxSplat = kMaxSplatSize;
    scratch->reserve(size_t(in.width));
    activeTransformRow()(in, scratch->output());
}

namespace {

// Warps the rows that reach destination rows [bandY0, bandY1), writing only those rows; a row
// that reaches two bands is transformed by both (a few rows per boundary: source rows map to
// destination curves that mostly run across the image).
template <WriteMode kMode>
void runRows(const std::vector<ViewJob>& views, const RowJob* begin, const RowJob* end,
             int bandY0, int bandY1, const WarpOptions& options, const DestBuffer& dest,
             RowScratch* scratch) {
    const Writer writer{dest, kMode, bandY0, bandY1};
    for (const RowJob* it = begin; it != end; ++it) {
        const RowJob& row = *it;
        if (row.destY1 <= bandY0 || row.destY0 >= bandY1) continue;
        const ViewJob& view = views[row.view];
        if (options.splat == Splat::kMesh) {
            meshRow(view, row, writer, scratch);
            continue;
        }
        transformRowJob(view, row, options.splat, dest, scratch);
        const float* disparity = view.view->disparity.row(row.y);
        const Rgba8* color = view.view->color.row(row.y);
        for (int x = row.x0; x < row.x1; ++x) {
            const size_t i = size_t(x - row.x0);
            if (scratch->rx0[i] >= scratch->rx1[i]) continue;
            const uint32_t bits = disparity[x] > 0.0f ? rgbaBits(color[x]) : dest.clearBits;
            splatPixel<kMode>(writer, *scratch, i, bits);
        }
    }
}

}  // namespace

void warpZBuffer(ThreadPool& pool, const std::vector<ViewJob>& views,
                 const std::vector<RowJob>& rows, const WarpOptions& options,
                 const DestBuffer& dest, std::vector<RowScratch>* scratch) {
    if (rows.empty()) return;
    const int threads = pool.threadCount();
    if (threads <= 1) {
        runRows<WriteMode::kMax>(views, rows.data(), rows.data() + rows.size(), 0, dest.height,
                                 options, dest, &(*scratch)[0]);
        return;
    }
    if (options.atomicWrites) {
        // Chunks of about equal pixel counts, 16 per thread, written with compare-and-swap.
        int64_t total = 0;
        for (const RowJob& r : rows) total += r.x1 - r.x0;
        const size_t chunkCount = std::min(rows.size(), size_t(threads) * 16);
        std::vector<size_t> bounds{0};
        int64_t acc = 0;
        for (size_t j = 0; j < rows.size(); ++j) {
            acc += rows[j].x1 - rows[j].x0;
            if (acc * int64_t(chunkCount) >= total * int64_t(bounds.size()) &&
                bounds.size() < chunkCount)
                bounds.push_back(j + 1);
        }
        if (bounds.back() != rows.size()) bounds.push_back(rows.size());
        pool.parallelFor(bounds.size() - 1, 1, [&](size_t c0, size_t c1) {
            RowScratch* s = &(*scratch)[size_t(currentThreadSlot())];
            for (size_t c = c0; c < c1; ++c)
                runRows<WriteMode::kAtomicMax>(views, rows.data() + bounds[c],
                                               rows.data() + bounds[c + 1], 0, dest.height,
                                               options, dest, s);
        });
        return;
    }
    // Band boundaries at equal shares of the source pixels, each row counted at the middle of
    // the destination rows it reaches. Four bands per thread, so a band whose rows splat more
    // (a magnified face) is absorbed by the others.
    std::vector<int64_t> weight(size_t(dest.height) + 1, 0);
    int64_t total = 0;
    for (const RowJob& r : rows) {
        weight[size_t((r.destY0 + r.destY1) / 2)] += r.x1 - r.x0;
        total += r.x1 - r.x0;
    }
    const int bandCount = std::min(dest.height, threads * 4);
    std::vector<int> bounds{0};
    int64_t acc = 0;
    for (int y = 0; y < dest.height; ++y) {
        acc += weight[size_t(y)];
        if (acc * bandCount >= total * int64_t(bounds.size()) && int(bounds.size()) < bandCount)
            bounds.push_back(y + 1);
    }
    if (bounds.back() != dest.height) bounds.push_back(dest.height);
    pool.parallelFor(bounds.size() - 1, 1, [&](size_t b0, size_t b1) {
        RowScratch* s = &(*scratch)[size_t(currentThreadSlot())];
        for (size_t b = b0; b < b1; ++b)
            runRows<WriteMode::kMax>(views, rows.data(), rows.data() + rows.size(), bounds[b],
                                     bounds[b + 1], options, dest, s);
    });
}

}  // namespace plx::warp::detail
