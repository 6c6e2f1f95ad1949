#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
#include <emmintrin.h>
#endif

#include <fmt/format.h>

#include <plx/stereo/reproject.h>

#include "byte_runs.h"

namespace plx::stereo {

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

Status checkTargets(const FirstEyeTargets& first, const SecondEyeTargets& second) {
    int w = first.color.width, h = first.color.height;
    auto same = [&](auto& v) { return v.width == w && v.height == h && v.data != nullptr; };
    if (w <= 0 || h <= 0 || !same(first.color) || !same(first.depth) || !same(first.id) ||
        !same(second.color) || !same(second.depth) || !same(second.id) || !same(second.holeMask))
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
    return Status::ok();
}

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
    explicit RowLandings(int w) : from(size_t(w) + 1, 0), color(size_t(w) + 1) {}
    bool landed(int t) const { return from[size_t(t)] >= tag; }
    int32_t column(int t) const { return from[size_t(t)] - tag; }
};

// The tag of row y of a w-wide image: (y + 1)(w + 1) exceeds row y - 1's largest landing,
// y (w + 1) + w - 1, and the slots' initial 0. checkTargets keeps it within int32_t.
int32_t rowTag(int y, int w) {
    return int32_t((int64_t(y) + 1) * (int64_t(w) + 1));
}

// One row's scatter: its first-eye depth and colour in, its landings (w + 1 slots each) out.
struct RowScatter {
    const float* srcDepth;
    const Rgba8* srcColor;
    int w;
    int32_t tag;
    int32_t* from;
    Rgba8* color;
};

// Which way a row is walked so that every collision is won by the pixel that comes later
// (McMillan's occlusion-compatible order, for the epipole at infinity along the rows). With
// a = perInvW <= 0 (left eye first) the offset a (1/w) + b falls as 1/w grows, so a nearer pixel
// moves further left. Two first-eye pixels x' < x land in one second-eye pixel only when
// |(x + off(x)) - (x' + off(x'))| < 1 with x - x' >= 1, which needs off(x) < off(x'), i.e. x
// strictly nearer: walking left to right, the later pixel is always the nearer one, and no depth
// comparison is needed; the result equals the depth test's (Fu Fig. 3) pixel for pixel. For
// a > 0 (right eye first) the mirror holds, right to left. The offset table's entries are
// monotone in 1/w in the same way, so the same order serves it.
enum class RowOrder { kLeftToRight, kRightToLeft };

// The scatter of one row: from[tx] = tag + x, color[tx] = its colour, in occlusion-compatible
// order. `offset(invW)` returns the offset plus the pixel centre. One landing: first-eye column x
// lands at x + 0.5 + offset, in the pixel floor() of it. The range test in float also drops
// positions too large for int (and NaN); those land in the spare slot w.
template <class Offset>
void land(const RowScatter& row, const Offset& offset, int x) {
    const float pos = float(x) + offset(row.srcDepth[x]);
    const int t = pos >= 0.0f && pos < float(row.w) ? int(pos) : row.w;
    row.from[t] = row.tag + x;
    row.color[t] = row.srcColor[x];
}

template <class Offset>
void scatterRow(const RowScatter& row, const Offset& offset, RowOrder order) {
    if (order == RowOrder::kLeftToRight)
        for (int x = 0; x < row.w; ++x) land(row, offset, x);
    else
        for (int x = row.w - 1; x >= 0; --x) land(row, offset, x);
}

// The direct form's offset a (1/w) + b, b including the pixel centre.
struct DirectOffset {
    float a = 0.0f, b = 0.0f;
    float operator()(float invW) const { return a * invW + b; }
};

// scatterRow for the direct form, four landings computed at a time with the same float
// operations in the same order (the build does not contract them). Four landings one column
// apart, as a surface's pixels mostly land (its disparity changes by a small fraction of a pixel
// per column), are stored as one vector each of columns and colours: their slots are distinct, so
// the order in which they are written does not matter. Any other four are stored one by one in
// occlusion-compatible order.
void scatterRow(const RowScatter& row, const DirectOffset& offset, RowOrder order) {
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
    const int w = row.w;
    const __m128 a = _mm_set1_ps(offset.a), b = _mm_set1_ps(offset.b);
    const __m128 zero = _mm_setzero_ps(), limit = _mm_set1_ps(float(w));
    const __m128i spare = _mm_set1_epi32(w);
    const __m128i lanes = _mm_set_epi32(3, 2, 1, 0);
    alignas(16) int32_t tx[4];
    // Lands columns x .. x + 3: true when they land one column apart, all four stored; else
    // their slots are left in tx.
    auto land4 = [&](int x) {
        const __m128i xi = _mm_add_epi32(_mm_set1_epi32(x), lanes);
        const __m128 d = _mm_loadu_ps(row.srcDepth + x);
        const __m128 pos = _mm_add_ps(_mm_cvtepi32_ps(xi), _mm_add_ps(_mm_mul_ps(a, d), b));
        // Inside [0, w) (false for NaN): its column; else the spare slot.
        const __m128 inside = _mm_and_ps(_mm_cmpge_ps(pos, zero), _mm_cmplt_ps(pos, limit));
        const __m128i col = _mm_cvttps_epi32(_mm_and_ps(pos, inside));
        const __m128i in = _mm_castps_si128(inside);
        const __m128i slot = _mm_or_si128(_mm_and_si128(in, col), _mm_andnot_si128(in, spare));
        // One shift for all four: the slots are consecutive. Slots in the spare one never are
        // (the shift differs by lane), so all four lie inside the row.
        const __m128i shift = _mm_sub_epi32(slot, xi);
        const __m128i same = _mm_cmpeq_epi32(shift, _mm_shuffle_epi32(shift, 0));
        if (_mm_movemask_epi8(same) == 0xffff) {
            const int t0 = _mm_cvtsi128_si32(slot);
            _mm_storeu_si128(reinterpret_cast<__m128i*>(row.from + t0),
                             _mm_add_epi32(xi, _mm_set1_epi32(row.tag)));
            _mm_storeu_si128(reinterpret_cast<__m128i*>(row.color + t0),
                             _mm_loadu_si128(reinterpret_cast<const __m128i*>(row.srcColor + x)));
            return true;
        }
        _mm_store_si128(reinterpret_cast<__m128i*>(tx), slot);
        return false;
    };
    int x = 0;
    if (order == RowOrder::kLeftToRight) {
        for (; x + 4 <= w; x += 4) {
            if (land4(x)) continue;
            for (int k = 0; k < 4; ++k) {
                row.from[tx[k]] = row.tag + x + k;
                row.color[tx[k]] = row.srcColor[x + k];
            }
        }
        for (; x < w; ++x) land(row, offset, x);
    } else {
        // Right to left: the columns the four-wide steps leave at the left end go last.
        const int head = w % 4;
        for (int x0 = w - 4; x0 >= head; x0 -= 4) {
            if (land4(x0)) continue;
            for (int k = 3; k >= 0; --k) {
                row.from[tx[k]] = row.tag + x0 + k;
                row.color[tx[k]] = row.srcColor[x0 + k];
            }
        }
        for (x = head - 1; x >= 0; --x) land(row, offset, x);
    }
#else
    scatterRow<DirectOffset>(row, offset, order);
#endif
}

// Depth 0 and ID 0 over the hole run [start, end) of row y, and the landed 1/w and ID beside it:
// what the fill, classifyHoles and fillExpansionHoles read of a second eye whose planes are not
// written in full.
void markHoleRun(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
                 const RowLandings& landings, int start, int end) {
    float* dstDepth = second.depth.row(y);
    uint32_t* dstId = second.id.row(y);
    auto copyLanded = [&](int t) {
        dstDepth[t] = first.depth.row(y)[landings.column(t)];
        dstId[t] = first.id.row(y)[landings.column(t)];
    };
    std::fill(dstDepth + start, dstDepth + end, 0.0f);
    std::fill(dstId + start, dstId + end, 0u);
    if (start > 0) copyLanded(start - 1);
    if (end < second.color.width) copyLanded(end);
}

// What a row with holes needs beyond its pixels: its runs listed (second.holeRuns) and, for a
// second eye without full planes, each run marked (markHoleRun). The row is still in cache.
void finishHoleRuns(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
                    const RowLandings& landings) {
    std::vector<HoleRun>* runs = second.holeRuns ? &second.holeRuns->rows[size_t(y)] : nullptr;
    forEachNonZeroRun(second.holeMask.row(y), second.color.width, [&](int start, int end) {
        if (runs) runs->push_back({start, end - 1});
        if (!second.depthAndIds) markHoleRun(first, second, y, landings, start, end);
    });
}

// One second-eye pixel from its landing: colour and hole byte, and depth and ID when
// second.depthAndIds.
inline void writePixel(const FirstEyeTargets& first, const SecondEyeTargets& second, int y, int t,
                       const RowLandings& landings) {
    const bool landed = landings.landed(t);
    const int32_t s = landed ? landings.column(t) : 0;
    second.color.row(y)[t] = landed ? landings.color[size_t(t)] : Rgba8{};
    second.holeMask.row(y)[t] = uint8_t(!landed);
    if (second.depthAndIds) {
        second.depth.row(y)[t] = landed ? first.depth.row(y)[s] : 0.0f;
        second.id.row(y)[t] = landed ? first.id.row(y)[s] : 0u;
    }
}

// Writes one second-eye row from its landings, in column order: colour and the hole byte at every
// pixel; depth and ID at every pixel when second.depthAndIds, else as markHoleRun says; the row's
// hole runs when second.holeRuns.
void writeRow(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
              const RowLandings& landings) {
    const int w = second.color.width;
    int t = 0;
    bool anyHole = false;
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
    // Four pixels a step: the landed colours (zeroed where none landed) and, with the planes,
    // the landings' first-eye depth and ID words gathered (column 0 where none landed, then
    // zeroed), written with streaming stores, which skip reading the destination lines first;
    // the hole bytes packed from the same mask.
    Rgba8* dstColor = second.color.row(y);
    auto aligned = [](const void* p) { return (reinterpret_cast<uintptr_t>(p) & 15) == 0; };
    for (; t < w && !aligned(dstColor + t); ++t) {
        writePixel(first, second, y, t, landings);
        anyHole |= !landings.landed(t);
    }
    const bool planes = second.depthAndIds;
    float* dstDepth = second.depth.row(y);
    uint32_t* dstId = second.id.row(y);
    if (!planes || (aligned(dstDepth + t) && aligned(dstId + t))) {
        const int32_t* from = landings.from.data();
        const Rgba8* landedColor = landings.color.data();
        const auto* srcDepth = reinterpret_cast<const int32_t*>(first.depth.row(y));
        const auto* srcId = reinterpret_cast<const int32_t*>(first.id.row(y));
        uint8_t* hole = second.holeMask.row(y);
        const __m128i tag = _mm_set1_epi32(landings.tag);
        __m128i anyMissed = _mm_setzero_si128();
        alignas(16) int32_t at[4];
        for (; t + 4 <= w; t += 4) {
            const __m128i f = _mm_loadu_si128(reinterpret_cast<const __m128i*>(from + t));
            const __m128i missed = _mm_cmplt_epi32(f, tag);
            anyMissed = _mm_or_si128(anyMissed, missed);
            const __m128i color =
                _mm_loadu_si128(reinterpret_cast<const __m128i*>(landedColor + t));
            _mm_stream_si128(reinterpret_cast<__m128i*>(dstColor + t),
                             _mm_andnot_si128(missed, color));
            if (planes) {
                _mm_store_si128(reinterpret_cast<__m128i*>(at),
                                _mm_andnot_si128(missed, _mm_sub_epi32(f, tag)));
                auto gather = [&](const int32_t* src) {
                    const __m128i v = _mm_set_epi32(src[at[3]], src[at[2]], src[at[1]], src[at[0]]);
                    return _mm_andnot_si128(missed, v);
                };
                _mm_stream_si128(reinterpret_cast<__m128i*>(dstDepth + t), gather(srcDepth));
                _mm_stream_si128(reinterpret_cast<__m128i*>(dstId + t), gather(srcId));
            }
            const __m128i bytes = _mm_packs_epi16(_mm_packs_epi32(missed, missed), missed);
            const int holeWord = _mm_cvtsi128_si32(_mm_and_si128(bytes, _mm_set1_epi8(1)));
            std::memcpy(hole + t, &holeWord, 4);
        }
        anyHole |= _mm_movemask_epi8(anyMissed) != 0;
    }
#endif
    for (; t < w; ++t) {
        writePixel(first, second, y, t, landings);
        anyHole |= !landings.landed(t);
    }
    if (second.holeRuns) second.holeRuns->rows[size_t(y)].clear();
    if (anyHole && (second.holeRuns || !second.depthAndIds))
        finishHoleRuns(first, second, y, landings);
}

// Rows per task: a 720-row frame gives ~45 tasks, enough to balance two to eight threads.
constexpr size_t kRowGrain = 16;

template <class Offset>
void reprojectRows(const FirstEyeTargets& first, const SecondEyeTargets& second, ThreadPool* pool,
                   const Offset& rowOffset, RowOrder order) {
    auto body = [&](size_t begin, size_t end) {
        // A copy: through a reference the compiler reloaded the coefficients at every pixel,
        // since the stores might change them.
        const Offset offset = rowOffset;
        RowLandings landings(first.color.width);
        for (size_t y = begin; y < end; ++y) {
            landings.tag = rowTag(int(y), first.color.width);
            const RowScatter row{first.depth.row(int(y)), first.color.row(int(y)),
                                 first.color.width,       landings.tag,
                                 landings.from.data(),    landings.color.data()};
            scatterRow(row, offset, order);
            writeRow(first, second, int(y), landings);
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

RowOrder orderFor(const DisparityLine& line) {
    return line.perInvW <= 0.0f ? RowOrder::kLeftToRight : RowOrder::kRightToLeft;
}

}  // namespace

Status reproject(const FirstEyeTargets& first, const DisparityLine& line,
                 const SecondEyeTargets& second, ThreadPool* pool) {
    if (Status s = checkTargets(first, second); !s.isOk()) return s;
    if (!std::isfinite(line.perInvW) || !std::isfinite(line.offsetPx))
        return errorStatus(ErrorCode::kInvalidArgument, "disparity line is not finite");
    reprojectRows(first, second, pool, DirectOffset{line.perInvW, line.offsetPx + 0.5f},
                  orderFor(line));
    return Status::ok();
}

Status reproject(const FirstEyeTargets& first, const OffsetLut& lut, const SecondEyeTargets& second,
                 ThreadPool* pool) {
    if (Status s = checkTargets(first, second); !s.isOk()) return s;
    reprojectRows(
        first, second, pool, [&lut](float invW) { return lut.centredOffset(invW); },
        orderFor(lut.line()));
    return Status::ok();
}

}  // namespace plx::stereo
