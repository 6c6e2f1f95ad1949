// McMillan's occlusion-compatible order (McMillan and Bishop 1995; Mark, Bishop, McMillan,
// "Speedup techniques"): without a z-buffer, a single reference is drawn so that nearer points
// land last. Points that can meet in one destination pixel lie on one epipolar line of the
// source, and along it the nearer one lies closer to the epipole when the destination eye is in
// front of the source camera (positive epipole), farther when behind. So the image is cut into
// up to four sheets by the epipole's row and column and each is drawn toward the epipole
// (positive) or away from it (negative): rows toward the epipole's row, pixels in a row toward
// its column. One thread: the sheets differ in size, the load balance problem the paper names.

#include <algorithm>
#include <cmath>

#include <plx/warp/equation.h>

#include "warp_internal.h"

namespace plx::warp::detail {

namespace {

// Appends to `order` the integers of [lo, hi) so that those with centre (x + 0.5) below `e` go
// ascending and the rest descending (toward e), or the reverse (away from e).
void orderToward(int lo, int hi, double e, bool toward, std::vector<int32_t>* order) {
    order->clear();
    const int split = int(std::clamp(std::floor(e - 0.5) + 1.0, double(lo), double(hi)));
    if (toward) {
        for (int x = lo; x < split; ++x) order->push_back(x);
        for (int x = hi - 1; x >= split; --x) order->push_back(x);
    } else {
        for (int x = split - 1; x >= lo; --x) order->push_back(x);
        for (int x = split; x < hi; ++x) order->push_back(x);
    }
}

}  // namespace

void warpOcclusionCompatible(const std::vector<ViewJob>& views, const std::vector<RowJob>& rows,
                             const Camera& destination, const WarpOptions& options,
                             const DestBuffer& dest, uint8_t* stamp, Transformed* transformed) {
    std::vector<int32_t> rowOrder, pixelOrder;
    size_t begin = 0;
    // The rows of each view are contiguous in `rows`, in ascending y.
    for (uint32_t vi = 0; vi < views.size(); ++vi) {
        size_t end = begin;
        while (end < rows.size() && rows[end].view == vi) ++end;
        const ViewJob& view = views[vi];
        glm::dvec3 ep = sourceEpipole(view.view->camera, destination);
        // At infinity (z = 0) a tiny positive z puts the epipole far out along its direction,
        // which orders the pixels the same way.
        const double scale = std::max(std::abs(ep.x), std::abs(ep.y));
        if (std::abs(ep.z) <= 1e-12 * scale) ep.z = std::max(1e-12 * scale, 1e-300);
        const bool toward = ep.z > 0;
        const double ex = ep.x / ep.z, ey = ep.y / ep.z;
        // Row jobs begin..end - 1 in drawing order: by their row's centre against ey.
        std::vector<int32_t> jobOrder;
        {
            std::vector<int32_t> ys;
            for (size_t j = begin; j < end; ++j) ys.push_back(int32_t(j - begin));
            size_t split = 0;
            while (split < ys.size() && double(rows[begin + split].y) + 0.5 < ey) ++split;
            if (toward) {
                for (size_t j = 0; j < split; ++j) jobOrder.push_back(ys[j]);
                for (size_t j = ys.size(); j-- > split;) jobOrder.push_back(ys[j]);
            } else {
                for (size_t j = split; j-- > 0;) jobOrder.push_back(ys[j]);
                for (size_t j = split; j < ys.size(); ++j) jobOrder.push_back(ys[j]);
            }
        }
        const Writer writer{dest, WriteMode::kPainter, 0, dest.height, stamp, uint8_t(vi + 1)};
        for (int32_t jo : jobOrder) {
            const RowJob& row = rows[begin + size_t(jo)];
            if (options.splat == Splat::kMesh) {
                orderToward(row.x0, std::max(row.x0, row.x1 - 1), ex, toward, &pixelOrder);
                (void)transformMeshRow(view, row, dest, transformed);
                meshRow(view, row, writer, *transformed, pixelOrder);
                continue;
            }
            (void)transformRowJob(view, row, options.splat, dest, transformed);
            orderToward(row.x0, row.x1, ex, toward, &pixelOrder);
            const float* disparity = view.view->disparity.row(row.y);
            const Rgba8* color = view.view->color.row(row.y);
            for (int32_t x : pixelOrder) {
                const size_t i = row.offset + size_t(x - row.x0);
                if (transformed->rx0[i] >= transformed->rx1[i]) continue;
                const uint32_t bits = disparity[x] > 0.0f ? rgbaBits(color[x]) : dest.clearBits;
                splatPixel<WriteMode::kPainter>(writer, *transformed, i, bits);
            }
        }
        begin = end;
    }
}

}  // namespace plx::warp::detail
