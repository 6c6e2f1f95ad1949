#pragma once
// Forward reprojection of the first eye's colour, depth (1/w) and ID targets into the second eye
// (Fu, Bao, Peng, sections 1-2): both eyes share the image rows, so every pixel moves along its
// row by a disparity that depends only on its depth, and collisions are resolved by depth.
//
// Disparity. With f the projection distance in pixels and e the separation, Heo eq. (1) gives
// x_right - x_left = e f (1/c - 1/Z) for the converged rig (its image shift e f / (2c) per eye)
// and -e f / Z for the parallel rig (Fu section 1, offset -a d / z_e). The depth target holds
// 1/w = 1/Z, so the offset is linear in it: second column = first column + a * (1/w) + b
// (DisparityLine); for the right eye first both coefficients change sign.
//
// Pixel positions. The first eye's pixel x is sampled at x + 0.5; it lands at x + 0.5 + offset
// and is written to the second eye's pixel whose span [tx, tx + 1) holds that position,
// tx = floor(x + 0.5 + offset). With offset 0 that is x itself, so zero separation reproduces the
// first eye bit for bit. Pixels landing outside [0, width) are dropped.
//
// Collisions (Fu section 2, Fig. 3). The nearest pixel (largest 1/w) that lands in a pixel is
// kept. Two pixels of equal 1/w never land in one pixel (their positions differ by their column
// distance), so the result is unique; it is reached without comparing depths by walking each row
// in occlusion-compatible order (reproject.cpp). Cleared first-eye pixels (1/w = 0,
// ID 0: nothing drawn, infinitely far) move too, by b, so the background is carried over.
//
// Gaps (beyond the paper). A surface the second eye sees more frontally spreads its pixels
// apart, and a farther pixel landing between two neighbours of it would show through it (a
// background seen through a wall, at wide separations). Where two neighbouring first-eye
// columns land two or more pixels apart in their order, each pixel between them whose landing
// lies farther than the nearer of the two is made a hole once the row is scattered, so that the
// hole fill draws the surface there (row_pass.h, RowGap; office:8 at 1 m separation: 33.9 ->
// 43.4 dB, docs/stereo-results.md). At an object's edge the two neighbours are two surfaces,
// and such a pixel is then drawn by the fill's search, exactly, where it would have been moved.
// The spread surface may also go on beyond its last pixel, the first eye placing its edge only
// to a pixel: where two neighbours land three or more pixels apart, a pixel beyond either, as
// far again less one, whose landing lies farther than that end by more than twice the two
// columns' difference in 1/w (so not the surface going on, nor anything beside an object's
// edge, where the difference is large) is made a hole too.
//
// Holes are the pixels nothing lands on, and those the gaps take: depth 0, ID 0, colour
// {0,0,0,0}, hole mask 1.

#include <cstdint>
#include <vector>

#include <plx/core/image.h>
#include <plx/core/parallel.h>
#include <plx/core/status.h>
#include <plx/core/stereo_rig.h>

namespace plx::stereo {

// second-eye column = first-eye column + perInvW * (1/w) + offsetPx, in pixels.
struct DisparityLine {
    float perInvW = 0.0f;   // a: -e f for the left eye first (pixels times scene units)
    float offsetPx = 0.0f;  // b: e f / c for the converged rig and left eye first, 0 parallel
};

// The disparity line from the first eye to the second for a rig description and a projection
// distance f in pixels ((height / 2) / tan(fovY / 2)). Errors: separation negative or not
// finite, convergence <= 0 or not finite (converged rig), f <= 0 or not finite.
Result<DisparityLine> disparityLine(const StereoRigDesc& desc, float focalPx);
// The same for a built rig (its description and projection distance).
DisparityLine disparityLine(const StereoRig& rig);

// Fu section 2's offset look-up table, indexed by quantised depth. The depth target is 1/w, as a
// z-buffer's window depth is affine in 1/z; the table quantises it uniformly over
// [0, maxInvW] into entries - 1 steps and rounds to the nearest step, so the offset it returns
// differs from the line's by at most |a| * maxInvW / (2 (entries - 1)) pixels (maxErrorPx()),
// which can move a pixel whose landing position is that close to a column boundary by one
// column. 1/w above maxInvW (nearer than the near plane the table was built for) is clamped to
// the last entry. Built once per rig and camera (the paper's "initialize offset look-up table").
class OffsetLut {
public:
    // Errors: maxInvW <= 0 or not finite, entries < 2 or > 2^24, line not finite.
    static Result<OffsetLut> create(const DisparityLine& line, float maxInvW, int entries = 4096);

    // Offset in pixels of a pixel with the given 1/w, plus the pixel centre's 0.5.
    float centredOffset(float invW) const { return mTable[entryIndex(invW, mScale, mLast)]; }
    // The entry of 1/w for a table of last + 1 entries and the given scale(): rounded to the
    // nearest, clamped to the table. The row kernels' scalar steps.
    static size_t entryIndex(float invW, float scale, float last) {
        float q = invW * scale + 0.5f;
        if (!(q >= 0.0f)) q = 0.0f;  // negative or NaN 1/w: not produced by a renderer
        if (q > last) q = last;
        return size_t(q);
    }
    float maxErrorPx() const { return mMaxErrorPx; }
    const DisparityLine& line() const { return mLine; }
    int entries() const { return int(mTable.size()); }
    // The entries (entry i: a i / scale() + b + 0.5) and the scale from 1/w to their index, for
    // the row kernels, whose vector forms repeat entryIndex's steps.
    const float* table() const { return mTable.data(); }
    float scale() const { return mScale; }

private:
    OffsetLut() = default;
    DisparityLine mLine;
    std::vector<float> mTable;  // entry i: a * i / scale + b + 0.5
    float mScale = 0.0f;        // (entries - 1) / maxInvW
    float mLast = 0.0f;         // entries - 1
    float mMaxErrorPx = 0.0f;
};

// The first eye's targets (read only).
struct FirstEyeTargets {
    ImageView<const Rgba8> color;
    ImageView<const float> depth;  // 1/w, 0 = cleared
    ImageView<const uint32_t> id;  // triangle index + 1, 0 = none
};

// One row's maximal run of hole pixels, columns x0 .. x1 inclusive.
struct HoleRun {
    int32_t x0 = 0, x1 = 0;
};

// Every row's hole runs as the row pass found them while writing the row: rows[y] in column
// order. findHoles (holes.h) merges them without scanning the mask again. Kept between frames, so
// that no call allocates once the rows have grown.
struct HoleRuns {
    std::vector<std::vector<HoleRun>> rows;
};

// The second eye's targets. reproject() writes colour and the hole mask at every pixel (a hole
// mask with no data is not written: the holes are then known only from holeRuns); depth and ID
// at every pixel when depthAndIds, else only where the hole search reads them: 0 at the hole
// pixels and the landed 1/w and ID beside each hole segment's ends (classifyHoles,
// fillExpansionHoles), leaving the rest as it was. A pair whose second eye is shown as colour only
// skips the two planes' 7.4 MB of writes at 1280x720. Without depthAndIds the depth and ID views
// may be the first eye's own (the same data and stride): each row's values beside its holes are
// read before the row is marked, and the first eye's planes hold the second eye's marks after.
struct SecondEyeTargets {
    ImageView<Rgba8> color;
    ImageView<float> depth;
    ImageView<uint32_t> id;
    ImageView<uint8_t> holeMask;  // 1 at the holes (see above), else 0; or no data
    bool depthAndIds = true;
    HoleRuns* holeRuns = nullptr;  // when given, reproject() lists each row's hole runs there too
};

// Reprojects the first eye into the second with the direct form (one multiply-add per pixel).
// This is the default: the table's lookup (float-to-int conversion, clamp, load) costs more than
// the multiply-add it replaces, where the paper's table saved a division per pixel (plx_stereo_
// bench BM_Reproject measures both).
// Rows run in parallel on `pool` when given (Fu section 1's parallel mode), else on the calling
// thread; the result does not depend on the thread count. Errors: targets of different sizes,
// an empty target, a line that is not finite, second-eye depth or ID planes that overlap the
// first eye's (unless they are the first eye's two planes themselves and depthAndIds is false).
// Precondition: the colour and hole mask targets overlap no other target.
Status reproject(const FirstEyeTargets& first, const DisparityLine& line,
                 const SecondEyeTargets& second, ThreadPool* pool = nullptr);
// The same with the offset look-up table (see OffsetLut for its error).
Status reproject(const FirstEyeTargets& first, const OffsetLut& lut, const SecondEyeTargets& second,
                 ThreadPool* pool = nullptr);

}  // namespace plx::stereo
