// The z-buffer pass (Mark, Bishop, McMillan, "Speedup techniques": "our current parallel
// implementation instead uses a z-buffer to resolve visibility"): every clipped row transformed
// once, then splatted band by band (warper.cpp says why).

#include <algorithm>
#include <bit>

#include <plx/warp/splat.h>

#include "warp_internal.h"

namespace plx::warp::detail {

namespace {

// A key (float bits of 1/w, plus one) with its 1/w scaled: a set's compositing handicap.
uint32_t scaledKey(uint32_t key, float scale) {
    return std::bit_cast<uint32_t>(std::bit_cast<float>(key - 1u) * scale) + 1u;
}

}  // namespace

std::pair<int32_t, int32_t> transformRowJob(const ViewJob& view, const RowJob& row, Splat splat,
                                            const DestBuffer& dest, Transformed* out) {
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
    in.splat = splat == Splat::kPoint      ? RowSplat::kPoint
               : splat == Splat::kFixed2x2 ? RowSplat::kFixed2x2
                                           : RowSplat::kDerivative;
    in.destWidth = float(dest.width);
    in.destHeight = float(dest.height);
    in.maxSplat = kMaxSplatSize;
    const RowReach reach = activeTransformRow()(in, out->at(row.offset));
    if (view.depthScale != 1.0f) {
        for (size_t i = row.offset, end = i + size_t(row.x1 - row.x0); i < end; ++i)
            if (out->rx0[i] < out->rx1[i]) out->key[i] = scaledKey(out->key[i], view.depthScale);
    }
    return {reach.y0, reach.y1};
}

namespace {

// Splats the rows that reach destination rows [bandY0, bandY1), writing only those rows, from
// their transforms.
template <WriteMode kMode>
void runRows(const std::vector<ViewJob>& views, const RowJob* begin, const RowJob* end,
             size_t firstRow, int bandY0, int bandY1, const WarpOptions& options,
             const DestBuffer& dest, const Transformed& t) {
    const Writer writer{dest, kMode, bandY0, bandY1};
    const auto splat = activeSplatRow();
    for (const RowJob* it = begin; it != end; ++it) {
        const RowJob& row = *it;
        if (row.destY1 <= bandY0 || row.destY0 >= bandY1) continue;
        const ViewJob& view = views[row.view];
        const auto [reachY0, reachY1] = t.rowReach[size_t(it - begin) + firstRow];
        if (reachY1 <= bandY0 || reachY0 >= bandY1) continue;
        if (options.splat == Splat::kMesh) {
            meshRow(view, row, writer, t);
            continue;
        }
        const float* disparity = view.view->disparity.row(row.y);
        const Rgba8* color = view.view->color.row(row.y);
        if constexpr (kMode == WriteMode::kMax) {
            // The band's only writer: the per-ISA splat kernel.
            SplatRowInput in;
            in.rx0 = t.rx0.data() + row.offset;
            in.rx1 = t.rx1.data() + row.offset;
            in.ry0 = t.ry0.data() + row.offset;
            in.ry1 = t.ry1.data() + row.offset;
            in.key = t.key.data() + row.offset;
            in.disparity = disparity + row.x0;
            in.color = color + row.x0;
            in.count = row.x1 - row.x0;
            in.clearBits = dest.clearBits;
            in.words = dest.words;
            in.stride = dest.stride;
            in.bandY0 = bandY0;
            in.bandY1 = bandY1;
            splat(in);
            continue;
        }
        for (int x = row.x0; x < row.x1; ++x) {
            const size_t i = row.offset + size_t(x - row.x0);
            if (t.rx0[i] >= t.rx1[i] || t.ry1[i] <= bandY0 || t.ry0[i] >= bandY1) continue;
            const uint32_t bits = disparity[x] > 0.0f ? rgbaBits(color[x]) : dest.clearBits;
            splatPixel<kMode>(writer, t, i, bits);
        }
    }
}

}  // namespace

void warpZBuffer(ThreadPool& pool, const std::vector<ViewJob>& views,
                 const std::vector<RowJob>& rows, const WarpOptions& options,
                 const DestBuffer& dest, Transformed* transformed,
                 const std::function<void(int, int)>& finish) {
    const int threads = pool.threadCount();
    // Every row transformed once (the vector kernel), before any band splats it.
    transformed->rowReach.resize(rows.size());
    pool.parallelFor(rows.size(), 16, [&](size_t r0, size_t r1) {
        for (size_t r = r0; r < r1; ++r) {
            const ViewJob& view = views[rows[r].view];
            transformed->rowReach[r] =
                options.splat == Splat::kMesh
                    ? transformMeshRow(view, rows[r], dest, transformed)
                    : transformRowJob(view, rows[r], options.splat, dest, transformed);
        }
    });
    if (threads > 1 && options.atomicWrites) {
        // Chunks of about equal pixel counts, 16 per thread, written with compare-and-swap.
        int64_t total = 0;
        for (const RowJob& r : rows) total += r.x1 - r.x0;
        const size_t chunkCount = std::max<size_t>(1, std::min(rows.size(), size_t(threads) * 16));
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
            for (size_t c = c0; c < c1; ++c)
                runRows<WriteMode::kAtomicMax>(views, rows.data() + bounds[c],
                                               rows.data() + bounds[c + 1], bounds[c], 0,
                                               dest.height, options, dest, *transformed);
        });
        pool.parallelFor(size_t(dest.height), 16,
                         [&](size_t y0, size_t y1) { finish(int(y0), int(y1)); });
        return;
    }
    // Destination bands, two per thread (one band with one thread), cut at equal shares of
    // the estimated work: each row's source pixels counted at the middle of the destination
    // rows its splats reach, at kSplatCost times a destination pixel's unpack (perf: the splat
    // takes about 40 times the unpack's time per pixel). Fewer, larger bands cost less: on the
    // display loop one band of 720 rows took 3.6-3.9 ms of CPU per frame against 4.4-4.8 with
    // 128-row bands and 5.2-5.4 with 32-row bands (each band passes over every row job and
    // splits the splats on its edges); two per thread leave room for a thread that loses its
    // core for a while.
    constexpr int64_t kSplatCost = 40;
    const int bandCount = threads <= 1 ? 1 : std::min(dest.height, threads * 2);
    std::vector<int> bounds{0};
    if (bandCount > 1) {
        std::vector<int64_t> weight(size_t(dest.height), int64_t(dest.width));
        for (size_t r = 0; r < rows.size(); ++r) {
            const auto [y0, y1] = transformed->rowReach[r];
            if (y0 < y1) weight[size_t((y0 + y1) / 2)] += kSplatCost * (rows[r].x1 - rows[r].x0);
        }
        int64_t total = 0;
        for (int64_t w : weight) total += w;
        int64_t acc = 0;
        for (int y = 0; y < dest.height && int(bounds.size()) < bandCount; ++y) {
            acc += weight[size_t(y)];
            if (acc * bandCount >= total * int64_t(bounds.size())) bounds.push_back(y + 1);
        }
    }
    if (bounds.back() != dest.height) bounds.push_back(dest.height);
    pool.parallelFor(bounds.size() - 1, 1, [&](size_t b0, size_t b1) {
        for (size_t b = b0; b < b1; ++b) {
            runRows<WriteMode::kMax>(views, rows.data(), rows.data() + rows.size(), 0, bounds[b],
                                     bounds[b + 1], options, dest, *transformed);
            finish(bounds[b], bounds[b + 1]);
        }
    });
}

}  // namespace plx::warp::detail
