#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
#include <emmintrin.h>
#endif

#include <fmt/format.h>

#include <plx/stereo/reproject.h>

#include "byte_runs.h"
#include "row_pass.h"

namespace plx::stereo {

namespace detail {
namespace {
// The active ISA's row kernels (row_pass.inl): scalar (SSE2) or AVX2.
auto activeScatterDirectRow() {
    return PLX_ISA_PICK_UP_TO_AVX2(scatterDirectRow);
}
auto activeScatterTableRow() {
    return PLX_ISA_PICK_UP_TO_AVX2(scatterTableRow);
}
auto activeWriteRowPixels() {
    return PLX_ISA_PICK_UP_TO_AVX2(writeRowPixels);
}
}  // namespace
}  // namespace detail

Result<DisparityLine> disparityLine(const StereoRigDesc& desc, float focalPx) {
    if (!(desc.separation >= 0.0f) || !std::isfinite(desc.separation))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("eye separation {} must be a finite number >= 0", desc.separation));
    bool converged = desc.type == StereoRigType::kConverged;
    if (converged && (!(desc.convergence > 0.0f) || !std::isfinite(desc.convergence)))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("convergence distance {} must be a finite number > 0", desc.convergence));
    if (!(focalPx > 0.0f) || !std::isfinite(focalPx))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("projection distance {} px must be finite and > 0", focalPx));
    // Heo eq. (1): x_right - x_left = e f (1/c - 1/Z) (converged), -e f / Z (parallel).
    float ef = desc.separation * focalPx;
    DisparityLine line{-ef, converged ? ef / desc.convergence : 0.0f};
    if (desc.firstEye == Eye::kRight) line = {-line.perInvW, -line.offsetPx};
    return line;
}

DisparityLine disparityLine(const StereoRig& rig) {
    return *disparityLine(rig.desc(), rig.projectionDistancePx());
}

Result<OffsetLut> OffsetLut::create(const DisparityLine& line, float maxInvW, int entries) {
    if (!(maxInvW > 0.0f) || !std::isfinite(maxInvW))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("largest 1/w {} must be finite and > 0", maxInvW));
    if (entries < 2 || entries > (1 << 24))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("offset table of {} entries (2 .. 2^24)", entries));
    if (!std::isfinite(line.perInvW) || !std::isfinite(line.offsetPx))
        return errorStatus(ErrorCode::kInvalidArgument, "disparity line is not finite");
    OffsetLut lut;
    lut.mLine = line;
    lut.mLast = float(entries - 1);
    lut.mScale = lut.mLast / maxInvW;
    lut.mTable.resize(size_t(entries));
    for (int i = 0; i < entries; ++i) {
        double invW = double(i) * double(maxInvW) / double(entries - 1);
        lut.mTable[size_t(i)] = float(double(line.perInvW) * invW + line.offsetPx + 0.5);
    }
    // Rounding to the nearest step leaves at most half a step of 1/w.
    lut.mMaxErrorPx = std::fabs(line.perInvW) * maxInvW / (2.0f * lut.mLast);
    return lut;
}

namespace {

template <class A, class B>
bool overlap(const ImageView<A>& a, const ImageView<B>& b) {
    auto begin = [](const auto& v) { return reinterpret_cast<uintptr_t>(v.data); };
    auto end = [](const auto& v) {
        return reinterpret_cast<uintptr_t>(v.row(v.height - 1) + v.width);
    };
    return begin(a) < end(b) && begin(b) < end(a);
}

template <class T>
bool sameView(const ImageView<const T>& a, const ImageView<T>& b) {
    return a.data == b.data && a.strideElems == b.strideElems;
}

// Apart or, for a second eye without depthAndIds, the same views (SecondEyeTargets).
Status checkPlanesApart(const FirstEyeTargets& first, const SecondEyeTargets& second) {
    if (sameView(first.depth, second.depth) && sameView(first.id, second.id)) {
        if (!second.depthAndIds) return Status::ok();
        return errorStatus(ErrorCode::kInvalidArgument,
                           "a second eye with depth and IDs in full cannot share the first eye's "
                           "depth and ID planes");
    }
    if (overlap(first.depth, second.depth) || overlap(first.depth, second.id) ||
        overlap(first.id, second.depth) || overlap(first.id, second.id))
        return errorStatus(ErrorCode::kInvalidArgument,
                           "the second eye's depth and ID planes overlap the first eye's without "
                           "being the same two planes");
    return Status::ok();
}

Status checkTargets(const FirstEyeTargets& first, const SecondEyeTargets& second) {
    int w = first.color.width, h = first.color.height;
    auto same = [&](auto& v) { return v.width == w && v.height == h && v.data != nullptr; };
    if (w <= 0 || h <= 0 || !same(first.color) || !same(first.depth) || !same(first.id) ||
        !same(second.color) || !same(second.depth) || !same(second.id) ||
        (second.holeMask.data && !same(second.holeMask)))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("reprojection targets differ in size or are empty (first eye {}x{}, "
                        "depth {}x{}, ID {}x{}; second eye {}x{}, depth {}x{}, ID {}x{}, hole "
                        "mask {}x{})",
                        w, h, first.depth.width, first.depth.height, first.id.width,
                        first.id.height, second.color.width, second.color.height,
                        second.depth.width, second.depth.height, second.id.width, second.id.height,
                        second.holeMask.width, second.holeMask.height));
    // rowTag: the last row's largest landing, h (w + 1) + w - 1, must fit an int32_t.
    if (int64_t(h) * (int64_t(w) + 1) + w > std::numeric_limits<int32_t>::max())
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("reprojection targets of {}x{} pixels are too large for "
                                       "the row pass's 32-bit landing tags",
                                       w, h));
    return checkPlanesApart(first, second);
}

// A hole run [start, end) of a row and the landed 1/w and ID beside it (markHoleRuns).
struct MarkedRun {
    int start = 0, end = 0;
    float leftDepth = 0.0f, rightDepth = 0.0f;
    uint32_t leftId = 0, rightId = 0;
};

// A row's landings, kept apart from the images: the first-eye column that reached each
// second-eye pixel and that column's colour, each with one spare slot that takes every landing
// outside the row, so the scatter needs no range branch. The colour is moved in the scatter, where
// its source is read in order, rather than gathered by column afterwards: a gather's four
// scattered loads per vector cost more than a second store per landing.
//
// A landing stores its column plus the row's tag, which exceeds every value an earlier row of the
// same slots stored (rowTag): a slot below the tag received nothing in this row, so the slots are
// never cleared between rows.
struct RowLandings {
    std::vector<int32_t> from;
    std::vector<Rgba8> color;
    int32_t tag = 0;
    std::vector<MarkedRun> runs;  // the row's hole runs, for markHoleRuns
    std::vector<uint8_t> hole;    // the row's hole bytes where the second eye has no hole mask
    std::vector<detail::RowGap> gaps;  // the row's gaps, one at most per column
    int gapCount = 0;
    explicit RowLandings(int w)
        : from(size_t(w) + 1, 0), color(size_t(w) + 1), hole(size_t(w)), gaps(size_t(w)) {}
    int32_t column(int t) const { return from[size_t(t)] - tag; }
};

// The tag of row y of a w-wide image: (y + 1)(w + 1) exceeds row y - 1's largest landing,
// y (w + 1) + w - 1, and the slots' initial 0. checkTargets keeps it within int32_t.
int32_t rowTag(int y, int w) {
    return int32_t((int64_t(y) + 1) * (int64_t(w) + 1));
}

// Which way a row is walked so that every collision is won by the pixel that comes later
// (McMillan's occlusion-compatible order, for the epipole at infinity along the rows). With
// a = perInvW <= 0 (left eye first) the offset a (1/w) + b falls as 1/w grows, so a nearer pixel
// moves further left. Two first-eye pixels x' < x land in one second-eye pixel only when
// |(x + off(x)) - (x' + off(x'))| < 1 with x - x' >= 1, which needs off(x) < off(x'), i.e. x
// strictly nearer: walking left to right, the later pixel is always the nearer one, and no depth
// comparison is needed; the result equals the depth test's (Fu Fig. 3) pixel for pixel. For
// a > 0 (right eye first) the mirror holds, right to left. The offset table's entries are
// monotone in 1/w in the same way, so the same order serves it.
bool walksLeftToRight(const DisparityLine& line) {
    return line.perInvW <= 0.0f;
}

using detail::RowScatter;

// Takes off each landing in slots [begin, end) whose first-eye 1/w is below `limit`.
void takeOffFarther(const RowScatter& row, int begin, int end, float limit) {
    if (!(limit > 0.0f)) return;  // nothing lies farther
    for (int t = begin; t < end; ++t) {
        const int32_t from = row.from[t];
        if (from >= row.tag && row.srcDepth[from - row.tag] < limit) row.from[t] = 0;
    }
}

// The row's gaps closed (reproject.h): each landing between the ends of a RowGap that lies
// farther than the nearer end is taken off. After the whole row, so that what lands in a gap
// later in the walk is judged too. Beyond each end, over the gap's width less one, the surface
// may go on (the first eye places its edge to a pixel, which the spread widens): a landing
// there farther than the end by more than two of the surface's steps between the ends is taken
// off too. A gap between two surfaces (an object's edge) has a step so large that nothing is.
void closeGaps(const RowScatter& row) {
    for (const detail::RowGap& gap : std::span(row.gaps, size_t(*row.gapCount))) {
        const float depthA = row.srcDepth[gap.xA], depthB = row.srcDepth[gap.xB];
        const int lo = std::min(gap.tA, gap.tB), hi = std::max(gap.tA, gap.tB);
        takeOffFarther(row, lo + 1, hi, std::max(depthA, depthB));
        if (hi - lo < 3) continue;  // the edge lies within a pixel of the end, as unspread
        const float margin = 2.0f * std::fabs(depthA - depthB);
        const float depthLo = gap.tA < gap.tB ? depthA : depthB;
        const float depthHi = gap.tA < gap.tB ? depthB : depthA;
        takeOffFarther(row, std::max(0, lo - (hi - lo) + 1), lo, depthLo - margin);
        takeOffFarther(row, hi + 1, std::min(row.w, hi + (hi - lo)), depthHi - margin);
    }
    *row.gapCount = 0;
}

// Depth 0 and ID 0 over each hole run of row y, and the landed 1/w and ID beside it: what the
// fill, classifyHoles and fillExpansionHoles read of a second eye whose planes are not written in
// full. Every value beside the runs is read before any run is marked, since the second eye's
// planes may be the first eye's (SecondEyeTargets).
void markHoleRuns(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
                  RowLandings& landings) {
    const float* srcDepth = first.depth.row(y);
    const uint32_t* srcId = first.id.row(y);
    const int w = second.color.width;
    for (MarkedRun& run : landings.runs) {
        if (run.start > 0) {
            const int from = landings.column(run.start - 1);
            run.leftDepth = srcDepth[from];
            run.leftId = srcId[from];
        }
        if (run.end < w) {
            const int from = landings.column(run.end);
            run.rightDepth = srcDepth[from];
            run.rightId = srcId[from];
        }
    }
    float* dstDepth = second.depth.row(y);
    uint32_t* dstId = second.id.row(y);
    for (const MarkedRun& run : landings.runs) {
        std::fill(dstDepth + run.start, dstDepth + run.end, 0.0f);
        std::fill(dstId + run.start, dstId + run.end, 0u);
        if (run.start > 0) {
            dstDepth[run.start - 1] = run.leftDepth;
            dstId[run.start - 1] = run.leftId;
        }
        if (run.end < w) {
            dstDepth[run.end] = run.rightDepth;
            dstId[run.end] = run.rightId;
        }
    }
}

// Row y's hole bytes: the hole mask's row, or without a mask the landings' own row, which stays
// in L1 (a colour-only pair leaves its 0.9 MB mask unwritten at 1280x720).
uint8_t* holeRow(const SecondEyeTargets& second, int y, RowLandings& landings) {
    return second.holeMask.data ? second.holeMask.row(y) : landings.hole.data();
}

// What a row with holes needs beyond its pixels: its runs listed (second.holeRuns) and, for a
// second eye without full planes, marked (markHoleRuns). The row is still in cache.
void finishHoleRuns(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
                    RowLandings& landings) {
    std::vector<HoleRun>* runs = second.holeRuns ? &second.holeRuns->rows[size_t(y)] : nullptr;
    landings.runs.clear();
    forEachNonZeroRun(holeRow(second, y, landings), second.color.width, [&](int start, int end) {
        if (runs) runs->push_back({start, end - 1});
        if (!second.depthAndIds) landings.runs.push_back({start, end});
    });
    if (!second.depthAndIds) markHoleRuns(first, second, y, landings);
}

// Writes one second-eye row from its landings (detail::writeRowPixels): colour and the hole
// byte at every pixel; depth and ID at every pixel when second.depthAndIds, else as markHoleRuns
// says; the row's hole runs when second.holeRuns.
void writeRow(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
              RowLandings& landings, bool (*writeRowPixels)(const detail::RowWrite&)) {
    detail::RowWrite row{landings.from.data(), landings.color.data(), landings.tag,
                         second.color.width,   second.color.row(y),   holeRow(second, y, landings)};
    if (second.depthAndIds) {
        row.srcDepth = reinterpret_cast<const int32_t*>(first.depth.row(y));
        row.srcId = reinterpret_cast<const int32_t*>(first.id.row(y));
        row.dstDepth = reinterpret_cast<int32_t*>(second.depth.row(y));
        row.dstId = reinterpret_cast<int32_t*>(second.id.row(y));
    }
    const bool anyHole = writeRowPixels(row);
    if (second.holeRuns) second.holeRuns->rows[size_t(y)].clear();
    if (anyHole && (second.holeRuns || !second.depthAndIds))
        finishHoleRuns(first, second, y, landings);
}

// Rows per task: a 720-row frame gives ~45 tasks, enough to balance two to eight threads.
constexpr size_t kRowGrain = 16;

// The row pass: each row scattered by `scatter(row)` into its landings, then written.
template <class Scatter>
void reprojectRows(const FirstEyeTargets& first, const SecondEyeTargets& second, ThreadPool* pool,
                   const Scatter& scatter) {
    const auto writeRowPixels = detail::activeWriteRowPixels();
    auto body = [&](size_t begin, size_t end) {
        RowLandings landings(first.color.width);
        for (size_t y = begin; y < end; ++y) {
            landings.tag = rowTag(int(y), first.color.width);
            const RowScatter row{first.depth.row(int(y)),
                                 first.color.row(int(y)),
                                 first.color.width,
                                 landings.tag,
                                 landings.from.data(),
                                 landings.color.data(),
                                 second.depthAndIds ? nullptr : first.id.row(int(y)),
                                 landings.gaps.data(),
                                 &landings.gapCount};
            scatter(row);
            closeGaps(row);
            writeRow(first, second, int(y), landings, writeRowPixels);
        }
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
        _mm_sfence();  // streaming stores are weakly ordered: complete them before the join
#endif
    };
    size_t rows = size_t(first.color.height);
    if (second.holeRuns) second.holeRuns->rows.resize(rows);
    if (pool)
        pool->parallelFor(rows, kRowGrain, body);
    else
        body(0, rows);
}

}  // namespace

Status reproject(const FirstEyeTargets& first, const DisparityLine& line,
                 const SecondEyeTargets& second, ThreadPool* pool) {
    if (Status s = checkTargets(first, second); !s.isOk()) return s;
    if (!std::isfinite(line.perInvW) || !std::isfinite(line.offsetPx))
        return errorStatus(ErrorCode::kInvalidArgument, "disparity line is not finite");
    const auto scatterDirectRow = detail::activeScatterDirectRow();
    const float a = line.perInvW, b = line.offsetPx + 0.5f;
    const bool leftToRight = walksLeftToRight(line);
    reprojectRows(first, second, pool,
                  [&](const RowScatter& row) { scatterDirectRow(row, a, b, leftToRight); });
    return Status::ok();
}

Status reproject(const FirstEyeTargets& first, const OffsetLut& lut, const SecondEyeTargets& second,
                 ThreadPool* pool) {
    if (Status s = checkTargets(first, second); !s.isOk()) return s;
    const auto scatterTableRow = detail::activeScatterTableRow();
    const detail::OffsetTable offsets{lut.table(), lut.scale(), float(lut.entries() - 1)};
    const bool leftToRight = walksLeftToRight(lut.line());
    reprojectRows(first, second, pool,
                  [&](const RowScatter& row) { scatterTableRow(row, offsets, leftToRight); });
    return Status::ok();
}

}  // namespace plx::stereo
