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

template <WriteMode kMode>
void runRows(const std::vector<ViewJob>& views, const RowJob* begin, const RowJob* end,
             const WarpOptions& options, const Writer& writer, RowScratch* scratch) {
    for (const RowJob* row = begin; row != end; ++row) {
        const ViewJob& view = views[row->view];
        if (options.splat == Splat::kMesh) {
            meshRow(view, *row, writer, scratch);
            continue;
        }
        transformRowJob(view, *row, options.splat, writer.dest, scratch);
        const float* disparity = view.view->disparity.row(row->y);
        const Rgba8* color = view.view->color.row(row->y);
        for (int x = row->x0; x < row->x1; ++x) {
            const size_t i = size_t(x - row->x0);
            if (scratch->rx0[i] >= scratch->rx1[i]) continue;
            const uint32_t bits =
                disparity[x] > 0.0f ? rgbaBits(color[x]) : writer.dest.clearBits;
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
        runRows<WriteMode::kMax>(views, rows.data(), rows.data() + rows.size(), options,
                                 {dest, WriteMode::kMax}, &(*scratch)[0]);
        return;
    }
    // Chunks of about equal pixel counts: 16 per thread, so a chunk whose rows splat more (a
    // magnified face) is absorbed by the others.
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
    const Writer writer{dest, WriteMode::kAtomicMax};
    pool.parallelFor(bounds.size() - 1, 1, [&](size_t c0, size_t c1) {
        RowScratch* s = &(*scratch)[size_t(currentThreadSlot())];
        for (size_t c = c0; c < c1; ++c)
            runRows<WriteMode::kAtomicMax>(views, rows.data() + bounds[c],
                                           rows.data() + bounds[c + 1], options, writer, s);
    });
}

}  // namespace plx::warp::detail
