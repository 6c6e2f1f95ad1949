// The warp engine (warp.h): rows of every reference view clipped (clip.h), transformed by the
// per-ISA row kernel (warp_row.inl), splatted into one destination buffer whose 64-bit words
// pack (1/w key, colour) so that a z-buffer write is a single max, then unpacked and the holes
// filled (holes.h).
//
// Parallelism (Mark, Bishop, McMillan, "Speedup techniques": a z-buffer instead of the
// occlusion-compatible order, for load balance). Every clipped row is transformed once, rows
// split among the threads; then the destination is cut into bands, two per thread, at equal
// shares of the estimated splat and unpack work, so both cores stay busy on any pose. A thread
// splats every row that reaches its band and writes only inside it, with plain stores, so there
// are no write conflicts, then unpacks the band. The alternative (WarpOptions::atomicWrites)
// splits the rows into chunks and writes the packed word with compare-and-swap; both give the
// maximum word per pixel, so the image is deterministic and equal to the one-thread image.

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include <plx/core/parallel.h>
#include <plx/core/timing.h>
#include <plx/warp/clip.h>
#include <plx/warp/equation.h>
#include <plx/warp/holes.h>
#include <plx/warp/splat.h>
#include <plx/warp/warp.h>

#include "row_kernel.h"
#include "warp_internal.h"

namespace plx::warp {

namespace {}  // namespace

namespace {

// Unpacks destination rows [y0, y1) of the buffer into the frame (colour, 1/w, hole mask),
// clears the words for the next frame, counts each row's holes and, with fillHoles, fills them
// from the rear surface (rows with no covered pixel wait for fillEmptyRows). Run per band right
// after the band is warped, by the thread that warped it.
void finishRows(uint64_t* words, size_t stride, int y0, int y1, const WarpOptions& options,
                WarpFrame* out, int* rowHoles, int* rowFilled) {
    const int dw = out->color.width();
    const uint32_t clearBits = detail::rgbaBits(options.clearColor);
    const auto unpack = detail::activeUnpackRow();
    for (int y = y0; y < y1; ++y) {
        Rgba8* c = out->color.row(y);
        float* d = out->depth.row(y);
        uint8_t* m = out->holeMask.row(y);
        const int holes = unpack(words + size_t(y) * stride, dw, clearBits, c, d, m);
        rowHoles[y] = holes;
        if (options.fillHoles && holes > 0)
            rowFilled[y] = std::max(0, fillRowRearSurface(c, d, m, dw));
    }
}

}  // namespace

struct Warper::Impl {
    explicit Impl(int threads) : pool(threads) {}
    ThreadPool pool;
    // Destination words (key << 32 | colour; 0 = not written), rows `stride` words apart, from
    // the first 32-byte boundary of `buffer`.
    std::vector<uint64_t> buffer;
    uint64_t* words = nullptr;
    size_t stride = 0;
    std::vector<uint8_t> stamp;  // occlusion-compatible order: which view wrote last (+1)
    std::vector<int> rowHoles;   // per destination row, its hole pixels before the fill
    std::vector<int> rowFilled;  // per destination row, holes the row fill filled
    std::vector<detail::ViewJob> views;
    std::vector<detail::RowJob> rows;
    detail::Transformed transformed;  // the row transforms of the frame
};

Warper::Warper(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
Warper::~Warper() = default;

Result<std::unique_ptr<Warper>> Warper::create(int threads) {
    PLX_RETURN_IF_ERROR(checkThreadCount(threads, "warper threads"));
    return std::unique_ptr<Warper>(new Warper(std::make_unique<Impl>(threads)));
}

int Warper::threadCount() const {
    return mImpl->pool.threadCount();
}

Status Warper::warp(const ReferenceSet& set, const Camera& destination, const WarpOptions& options,
                    WarpFrame* out, WarpStats* stats) {
    const ReferenceSet* sets[] = {&set};
    return warp(std::span<const ReferenceSet* const>(sets), destination, options, out, stats);
}

namespace detail {

Status checkWarpInputs(std::span<const ReferenceSet* const> sets, const Camera& destination) {
    if (!isFinite(destination.eyePos()) || !isFinite(destination.forwardDir()))
        return {ErrorCode::kInvalidArgument, "warp: destination camera is not finite"};
    size_t views = 0;
    for (size_t s = 0; s < sets.size(); ++s) {
        if (!sets[s]) return {ErrorCode::kInvalidArgument, "warp: reference set is null"};
        for (size_t v = 0; v < sets[s]->views.size(); ++v) {
            const ReferenceView& view = sets[s]->views[v];
            const std::string name =
                "warp: set " + std::to_string(s) + " view " + std::to_string(v);
            const int w = view.camera.width(), h = view.camera.height();
            if (!isFinite(view.camera.eyePos()))
                return {ErrorCode::kInvalidArgument, name + ": camera is not finite"};
            if (view.color.width() != w || view.color.height() != h ||
                view.disparity.width() != w || view.disparity.height() != h)
                return {ErrorCode::kInvalidArgument,
                        name + ": colour or disparity size differs from the camera's"};
            if (view.rowMinDisparity.size() != size_t(h) ||
                view.rowMaxDisparity.size() != size_t(h))
                return {ErrorCode::kInvalidArgument,
                        name + ": row disparity ranges missing (computeRowDisparityRange)"};
            ++views;
        }
    }
    if (views == 0) return {ErrorCode::kInvalidArgument, "warp: no reference views"};
    if (views > 254) return {ErrorCode::kOutOfRange, "warp: more than 254 reference views"};
    return {};
}

}  // namespace detail

Status Warper::warp(std::span<const ReferenceSet* const> sets, const Camera& destination,
                    const WarpOptions& options, WarpFrame* out, WarpStats* stats) {
    PLX_RETURN_IF_ERROR(detail::checkWarpInputs(sets, destination));
    if (!enumWithin(options.splat, Splat::kDerivative, Splat::kMesh) ||
        !enumWithin(options.order, WarpOrder::kZBuffer, WarpOrder::kOcclusionCompatible))
        return {ErrorCode::kInvalidArgument, "warp: unknown splat or order"};
    Stopwatch timer;
    Impl& im = *mImpl;
    const int dw = destination.width(), dh = destination.height();
    // The buffer is all zero between frames: finishRows clears each word it reads, which saves
    // a separate pass over 8 bytes per destination pixel.
    const size_t stride = (size_t(dw) + 3) & ~size_t(3);
    if (im.stride != stride || im.buffer.size() != stride * size_t(dh) + 4) {
        im.stride = stride;
        im.buffer.assign(stride * size_t(dh) + 4, 0);
        const size_t skew = (32 - reinterpret_cast<uintptr_t>(im.buffer.data()) % 32) % 32;
        im.words = im.buffer.data() + skew / 8;
    }

    WarpStats st;
    detail::planRows(sets, destination, options, &im.views, &im.rows, &st);
    const bool mesh = options.splat == Splat::kMesh;
    const size_t entries =
        im.rows.empty() ? 0 : im.rows.back().offset + detail::transformedSize(im.rows.back(), mesh);
    if (mesh) {
        if (im.transformed.vertices.size() < entries) im.transformed.vertices.resize(entries);
    } else {
        im.transformed.reserve(entries);
    }
    detail::DestBuffer dest{im.words, dw, dh, detail::rgbaBits(options.clearColor), stride};
    // Image::resize refills its pixels, so only on a size change; every pixel is written below.
    if (out->color.width() != dw || out->color.height() != dh) out->color.resize(dw, dh);
    if (out->depth.width() != dw || out->depth.height() != dh) out->depth.resize(dw, dh);
    if (out->holeMask.width() != dw || out->holeMask.height() != dh) out->holeMask.resize(dw, dh);
    im.rowHoles.assign(size_t(dh), 0);
    im.rowFilled.assign(size_t(dh), 0);
    const auto finish = [&](int y0, int y1) {
        finishRows(im.words, stride, y0, y1, options, out, im.rowHoles.data(), im.rowFilled.data());
    };
    if (options.order == WarpOrder::kOcclusionCompatible) {
        im.stamp.assign(stride * size_t(dh), 0);
        detail::warpOcclusionCompatible(im.views, im.rows, destination, options, dest,
                                        im.stamp.data(), &im.transformed);
        im.pool.parallelFor(size_t(dh), 16,
                            [&](size_t y0, size_t y1) { finish(int(y0), int(y1)); });
    } else {
        detail::warpZBuffer(im.pool, im.views, im.rows, options, dest, &im.transformed, finish);
    }
    for (int y = 0; y < dh; ++y) {
        st.holePixels += im.rowHoles[size_t(y)];
        st.holePixelsLeft += im.rowHoles[size_t(y)] - im.rowFilled[size_t(y)];
    }
    if (options.fillHoles && st.holePixelsLeft > 0)
        st.holePixelsLeft -=
            fillEmptyRows(&out->color, &out->depth, &out->holeMask, options.clearColor);
    st.ms = timer.elapsedMs();
    if (stats) *stats = st;
    return {};
}

namespace detail {

namespace {

// The quads of mesh row y (between source rows y and y + 1) that may be visible: the union of
// both rows' spans, widened one pixel left (a quad starts left of its right vertices).
RowSpan meshSpan(const WarpCoefficients& w, const ReferenceView& view, int y, RowSpan span,
                 const Camera& destination, float margin) {
    const RowSpan next = clipRow(w, y + 1, view.camera.width(), view.rowMinDisparity[size_t(y + 1)],
                                 view.rowMaxDisparity[size_t(y + 1)], destination.width(),
                                 destination.height(), margin);
    if (next.x0 < next.x1) {
        if (span.x0 < span.x1) {
            span.x0 = std::min(span.x0, next.x0);
            span.x1 = std::max(span.x1, next.x1);
            span.y0 = std::min(span.y0, next.y0);
            span.y1 = std::max(span.y1, next.y1);
        } else {
            span = next;
        }
    }
    if (span.x0 < span.x1) span.x0 = std::max(0, span.x0 - 1);
    return span;
}

}  // namespace

void planRows(std::span<const ReferenceSet* const> sets, const Camera& destination,
              const WarpOptions& options, std::vector<ViewJob>* views, std::vector<RowJob>* rows,
              WarpStats* st) {
    views->clear();
    rows->clear();
    const bool mesh = options.splat == Splat::kMesh;
    // How far (destination pixels) a splat or mesh triangle reaches from a warped position.
    const float margin = (mesh ? kMaxSplatSize : 0.5f * kMaxSplatSize) + 1.0f;
    const std::vector<float> scales =
        compositeDepthScales(sets, destination, options.compositeTolerance);
    for (size_t s = 0; s < sets.size(); ++s) {
        for (const ReferenceView& view : sets[s]->views) {
            const uint32_t vi = uint32_t(views->size());
            ViewJob job{&view, warpCoefficients(view.camera, destination), scales[s]};
            views->push_back(job);
            const int w = view.camera.width(), h = view.camera.height();
            // Mesh: row y stands for the quads between rows y and y + 1.
            const int rowCount = mesh ? h - 1 : h;
            for (int y = 0; y < rowCount; ++y) {
                ++st->rowsTotal;
                RowSpan span{0, w, 0, destination.height()};
                if (options.clipRows) {
                    span = clipRow(job.w, y, w, view.rowMinDisparity[size_t(y)],
                                   view.rowMaxDisparity[size_t(y)], destination.width(),
                                   destination.height(), margin);
                    if (mesh) span = meshSpan(job.w, view, y, span, destination, margin);
                    if (span.x0 >= span.x1) {
                        ++st->rowsSkipped;
                        continue;
                    }
                    if (span.x0 > 0 || span.x1 < w) ++st->rowsCut;
                }
                const uint32_t offset =
                    rows->empty()
                        ? 0
                        : rows->back().offset + uint32_t(transformedSize(rows->back(), mesh));
                rows->push_back({vi, y, span.x0, span.x1, span.y0, span.y1, offset});
                st->sourcePixels += span.x1 - span.x0;
            }
        }
    }
}

}  // namespace detail

Status warpStereo(Warper& warper, std::span<const ReferenceSet* const> sets, const Camera& center,
                  float separation, const WarpOptions& options, WarpFrame* left, WarpFrame* right,
                  WarpStats* stats) {
    if (!std::isfinite(separation) || separation < 0.0f)
        return {
            ErrorCode::kInvalidArgument,
            "warp stereo: separation " + std::to_string(separation) + " is negative or not finite"};
    // A parallel rig: both eyes keep the centre camera's orientation and projection.
    const Vec3 offset = center.rightDir() * (0.5f * separation);
    WarpStats total;
    for (int eye = 0; eye < 2; ++eye) {
        CameraDesc desc = center.desc();
        const Vec3 shift = eye == 0 ? -offset : offset;
        desc.eyePos += shift;
        desc.targetPos += shift;
        Result<Camera> camera = Camera::create(desc);
        if (!camera) return camera.status();
        WarpStats one;
        PLX_RETURN_IF_ERROR(warper.warp(sets, *camera, options, eye == 0 ? left : right, &one));
        total.sourcePixels += one.sourcePixels;
        total.rowsTotal += one.rowsTotal;
        total.rowsSkipped += one.rowsSkipped;
        total.rowsCut += one.rowsCut;
        total.holePixels += one.holePixels;
        total.holePixelsLeft += one.holePixelsLeft;
        total.ms += one.ms;
    }
    if (stats) *stats = total;
    return {};
}

}  // namespace plx::warp
