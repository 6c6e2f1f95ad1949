#pragma once
// Post-rendering warp (Mark, Bishop, McMillan): reference views that carry a generalised
// disparity per pixel are warped to a new pose by McMillan's perturbed-projective warp, with
// per-row clipping, a z-buffer, derivative-sized splats and the "rear surface" hole fill.
//
// This header is the module's contract; each algorithm lives in its own file:
//   reference.h  - reference views and reference sets (cube4, cube6, wide), rendered with raster
//   equation.h   - the warp coefficients from two cameras (derivation there), incremental rows
//   clip.h       - per-row clipping of a row's disparity parallelogram against the destination
//   splat.h      - reconstruction kernels: derivative, point, fixed 2x2, mesh
//   holes.h      - compositing several references by depth, the rear-surface fill
//   timewarp.h   - rotation-only timewarp (the peer the warp is measured against)
//
// Generalised disparity. A reference camera maps pixel centre (x + 0.5, y + 0.5) to the ray
// P (x + 0.5, y + 0.5, 1) whose component along the camera's forward axis is 1; a point at view
// depth w (distance along that axis) is then at C + w P (x, y, 1), and its disparity is
// delta = 1 / w, exactly the depth target's 1/w (no extra pass). delta = 0: nothing drawn there
// (infinitely far, the clear colour).

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <plx/core/core.h>
#include <plx/raster/raster.h>
#include <plx/warp/holes.h>

namespace plx::warp {

// One reference view: what a renderer drew for one camera, kept for warping.
struct ReferenceView {
    Camera camera{Camera::create({}).value()};
    Image<Rgba8> color;
    Image<float> disparity;              // delta = 1/w per pixel; 0 = nothing drawn
    std::vector<float> rowMinDisparity;  // per row, over all its pixels (0 counts)
    std::vector<float> rowMaxDisparity;
};

// cube4: the four horizontal sides of a cube around the eye (the paper's choice); cube6: all
// six; wide: one view wider than the display's field of view.
enum class ReferenceLayout { kCube4, kCube6, kWide };
Result<ReferenceLayout> parseReferenceLayout(const std::string& name);
const char* referenceLayoutName(ReferenceLayout layout);
// Views in a set of this layout: 4, 6 or 1.
int referenceViewCount(ReferenceLayout layout);

// A head pose: where the eye is and where it looks.
struct Pose {
    Vec3 eye{0.0f, 0.0f, 5.0f};
    Vec3 forward{0.0f, 0.0f, -1.0f};  // unit
    Vec3 up{0.0f, 1.0f, 0.0f};        // unit, not parallel to forward
};

struct ReferenceSetOptions {
    ReferenceLayout layout = ReferenceLayout::kCube4;
    int faceSize = 512;             // pixels per cube face side; wide: the view's height
    float wideFovDegrees = 100.0f;  // wide: vertical field of view (width = height * aspect)
    float wideAspect = 16.0f / 9.0f;
    float nearPlane = 0.05f;
    float farPlane = 1000.0f;
    raster::RenderOptions render;  // shading etc.; depth targets are always written
};

struct ReferenceSet {
    Pose pose;  // the pose the set was rendered for
    std::vector<ReferenceView> views;
    double renderMs = 0.0;
};

// Renders a reference set for `pose` with the given renderer. Errors: bad options (face size
// outside 1..Camera::kMaxImageSide, fov outside (0, 180)), a pose that is not finite or whose up
// is parallel to forward.
Status renderReferenceSet(raster::Renderer& renderer, const scene::Scene& scene, const Pose& pose,
                          const ReferenceSetOptions& options, ReferenceSet* out);

// Reconstruction kernels (Mark, Bishop, McMillan, "Image Reconstruction Kernel"; splat.h).
// kDerivative, the paper's, is the default: on the measured poses it leaves the fewest holes
// (0.01-2% of the frame against 84-86% for points, 36-49% for fixed 2x2 and 0.1-6% for the
// mesh) and the best PSNR but one (docs/warp-results.md).
enum class Splat { kDerivative, kPoint, kFixed2x2, kMesh };
Result<Splat> parseSplat(const std::string& name);  // derivative, point, fixed, mesh
const char* splatName(Splat splat);

// Visibility resolution: a z-buffer on the destination (the paper's parallel choice), or
// McMillan's occlusion-compatible order (one reference at a time, painter's order, no z test).
enum class WarpOrder { kZBuffer, kOcclusionCompatible };

struct WarpOptions {
    Splat splat = Splat::kDerivative;
    WarpOrder order = WarpOrder::kZBuffer;
    bool clipRows = true;   // per-row clipping (never changes the image)
    bool fillHoles = true;  // the rear-surface fill of what no reference covers
    // Z-buffer with several threads: false (default) gives each thread destination bands of
    // balanced work and plain writes; true splits the rows into chunks and
    // writes the packed (1/w, colour) word with compare-and-swap. Same image either way
    // (docs/warp-results.md has the timings).
    bool atomicWrites = false;
    // Several sets: the relative 1/w margin by which a set other than the one nearest the
    // destination must be nearer to win a pixel (holes.h, compositeDepthScales); 0 = plain
    // z-buffer.
    float compositeTolerance = kCompositeTolerance;
    Rgba8 clearColor{40, 44, 52, 255};  // what delta = 0 pixels warp as (the renderer's clear)
};

struct WarpStats {
    int64_t sourcePixels = 0;    // reference pixels processed (after row clipping)
    int64_t rowsTotal = 0;       // reference rows considered
    int64_t rowsSkipped = 0;     // rows wholly outside the destination
    int64_t rowsCut = 0;         // rows cut to their potentially visible span
    int64_t holePixels = 0;      // destination pixels no reference covered, before the fill
    int64_t holePixelsLeft = 0;  // after the fill (0 when fillHoles)
    double ms = 0.0;
};

// The warped destination image: colour, its 1/w (for compositing and tests) and a mask of the
// pixels no splat covered (1), filled by the rear-surface guess (2), or covered (0).
struct WarpFrame {
    Image<Rgba8> color;
    Image<float> depth;
    Image<uint8_t> holeMask;
};

// Warps reference sets to destination cameras. Keeps its scratch memory between frames and a
// thread pool of its own. One warp at a time per Warper.
class Warper {
public:
    static Result<std::unique_ptr<Warper>> create(int threads = 0);
    ~Warper();

    // Warps every view of every given set (newest first; several sets are composited by depth)
    // to `destination`, resizing `out` to its image. Errors: no views, non-finite cameras, a
    // splat or order outside its enum.
    Status warp(std::span<const ReferenceSet* const> sets, const Camera& destination,
                const WarpOptions& options, WarpFrame* out, WarpStats* stats = nullptr);
    // One set.
    Status warp(const ReferenceSet& set, const Camera& destination, const WarpOptions& options,
                WarpFrame* out, WarpStats* stats = nullptr);

    int threadCount() const;

private:
    struct Impl;
    explicit Warper(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// Both eyes of a head pose warped from the same reference sets (a parallel rig of the given
// separation around `center`). Errors: as Warper::warp, separation negative or not finite.
Status warpStereo(Warper& warper, std::span<const ReferenceSet* const> sets, const Camera& center,
                  float separation, const WarpOptions& options, WarpFrame* left, WarpFrame* right,
                  WarpStats* stats = nullptr);

// Rotation-only timewarp (what headset runtimes do without depth): the homography of the
// rotation from the reference camera to the destination, applied to the colour alone, as if
// every point were infinitely far. Pixels with no source are the clear colour.
Status rotationTimewarp(const ReferenceView& reference, const Camera& destination, Rgba8 clearColor,
                        Image<Rgba8>* out);

}  // namespace plx::warp
