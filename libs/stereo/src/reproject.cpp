#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <fmt/format.h>

#include <plx/stereo/reproject.h>

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
    return Status::ok();
}

// A row's landings, kept apart from the images: the nearest 1/w that reached each second-eye
// pixel and the first-eye column it came from (-infinity and -1 where none did), plus one spare
// slot that takes every landing outside the row, so the scatter needs no range branch.
struct RowLandings {
    std::vector<float> invW;
    std::vector<int32_t> from;
    explicit RowLandings(int w) : invW(size_t(w) + 1), from(size_t(w) + 1) {}
};

// One row (Fu section 2): every first-eye pixel moves by its offset, the nearest kept on
// collisions; `offset(invW)` returns the offset plus the pixel centre. The scatter touches only
// the row's landings (two small arrays that stay in L1), and a second pass writes each
// second-eye pixel once, in order. Scattering colour, depth, ID and the hole byte straight into
// the images, after clearing them, took 2.2 times as long (BM_Reproject,
// docs/stereo-results.md).
template <class Offset>
void reprojectRow(const FirstEyeTargets& first, const SecondEyeTargets& second, int y,
                  const Offset& rowOffset, RowLandings& landings) {
    // A copy: through a reference the compiler reloaded the coefficients at every pixel, since
    // the stores below might change them.
    const Offset offset = rowOffset;
    const int w = first.color.width;
    const float* srcDepth = first.depth.row(y);
    float* bestInvW = landings.invW.data();
    int32_t* from = landings.from.data();
    std::fill_n(bestInvW, w, -std::numeric_limits<float>::infinity());
    std::fill_n(from, w, -1);
    const float limit = float(w);
    for (int x = 0; x < w; ++x) {
        float invW = srcDepth[x];
        // Landing position x + 0.5 + offset; its pixel is floor() of it. The range test in float
        // also drops positions too large for int (and NaN); those land in the spare slot w.
        float pos = float(x) + offset(invW);
        int tx = pos >= 0.0f && pos < limit ? int(pos) : w;
        if (invW > bestInvW[tx]) {
            bestInvW[tx] = invW;
            from[tx] = x;
        }
    }
    const Rgba8* srcColor = first.color.row(y);
    const uint32_t* srcId = first.id.row(y);
    Rgba8* dstColor = second.color.row(y);
    float* dstDepth = second.depth.row(y);
    uint32_t* dstId = second.id.row(y);
    uint8_t* hole = second.holeMask.row(y);
    for (int t = 0; t < w; ++t) {
        int32_t x = from[t];
        bool landed = x >= 0;
        int32_t s = landed ? x : 0;
        Rgba8 color = srcColor[s];
        uint32_t id = srcId[s];
        dstColor[t] = landed ? color : Rgba8{};
        dstDepth[t] = landed ? bestInvW[t] : 0.0f;
        dstId[t] = landed ? id : 0u;
        hole[t] = uint8_t(!landed);
    }
}

// Rows per task: a 720-row frame gives ~45 tasks, enough to balance two to eight threads.
constexpr size_t kRowGrain = 16;

template <class Offset>
void reprojectRows(const FirstEyeTargets& first, const SecondEyeTargets& second, ThreadPool* pool,
                   const Offset& offset) {
    auto body = [&](size_t begin, size_t end) {
        RowLandings landings(first.color.width);
        for (size_t y = begin; y < end; ++y) reprojectRow(first, second, int(y), offset, landings);
    };
    size_t rows = size_t(first.color.height);
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
    float a = line.perInvW, b = line.offsetPx + 0.5f;
    reprojectRows(first, second, pool, [a, b](float invW) { return a * invW + b; });
    return Status::ok();
}

Status reproject(const FirstEyeTargets& first, const OffsetLut& lut, const SecondEyeTargets& second,
                 ThreadPool* pool) {
    if (Status s = checkTargets(first, second); !s.isOk()) return s;
    reprojectRows(first, second, pool, [&lut](float invW) { return lut.centredOffset(invW); });
    return Status::ok();
}

}  // namespace plx::stereo
