#pragma once
// Software rasterizer implementing the P-buffer renderer of Heo, Jung and Wohn (Fig. 6): the
// z-buffer algorithm extended with a polygon-ID target that is written together with colour and
// depth wherever the depth test passes.
//
// Pipeline (renderer.cpp): vertices are transformed in parallel; triangles are clipped in
// homogeneous space against the near and far planes and a guard band, culled (outside, back-facing
// when asked, covering no sample), and binned into screen tiles in submission order; tiles are
// then rasterised in parallel with exact fixed-point edge functions (8 sub-pixel bits, top-left
// fill rule) and perspective-correct attributes. reference.cpp holds a small scalar renderer that
// follows the same arithmetic one triangle at a time, against which tests check the fast path.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <plx/core/core.h>
#include <plx/scene/scene.h>

namespace plx::raster {

enum class Shading {
    kFlat,      // constant per triangle: Lambert on the face normal + ambient (the paper's shading)
    kGouraud,   // Lambert + ambient per vertex, interpolated
    kTextured,  // Gouraud lighting times the bilinear, mipmapped base-colour texture
};

// Parses "flat" / "constant", "gouraud", "textured".
Result<Shading> parseShading(const std::string& name);
const char* shadingName(Shading shading);

// Receives each tile of the ID target as soon as the renderer has finished drawing it: the
// P-buffer's last loop ("for each pixel: set the visible flag of pid", Heo, Jung, Wohn Fig. 6)
// run per tile by the thread that drew it, while the tile is still in that core's cache,
// instead of a separate single-threaded pass over the whole target afterwards.
// VisibleSetCollector (visible_set.h) is the one this module provides.
class TileIdVisitor {
public:
    virtual ~TileIdVisitor() = default;
    // Called once per tile, concurrently from the renderer's threads; `slot` (in
    // [0, Renderer::threadCount())) is distinct among threads running at the same time. The
    // tile is the rectangle [x0, x1] x [y0, y1] of `ids`.
    virtual void visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1, int y1,
                           int slot) = 0;
};

// What a render reports about visibility beyond the depth and ID targets: the outputs that only
// the consumers of the P-buffer (Heo, Jung, Wohn) read, such as the stereo module's visible set
// and its conservative widening. Every member is optional and costs nothing when left empty.
// None of them is allowed in a colour-only render (RenderOptions::colorOnly), which has no depth
// test; checkRenderRequest names the broken precondition.
struct VisibilityOutputs {
    // Second depth layer, both views or neither, each of the camera's image size: at each pixel
    // the nearest surface behind the visible one, its 1/w (0 = none) and ID (global triangle
    // index + 1, 0 = none). Cleared with the other targets. Needs depth and ID targets; turns
    // off coarse occlusion culling and tile memory for the render (hidden triangles count), so
    // it costs time. Read by the conservative visible set (surfaces a foreground edge hides from
    // one eye and reveals to the other).
    ImageView<float> depth2;
    ImageView<uint32_t> id2;
    // When set, receives (appended, global indices) the triangles that cover no sample centre
    // (smaller than a pixel, between samples) yet lie in front of the final depth somewhere in
    // the 3x3 pixels around their centre: visible polygons the sampling missed, which a slightly
    // shifted sampling (the other eye's) may hit. Full renders only (renderSubset reports none);
    // clipped triangles are not reported. Needs a depth target.
    std::vector<uint32_t>* unsampledVisible = nullptr;
    // When set, sees every finished tile of the ID target (TileIdVisitor), also when the targets
    // have no ID view (the tile's IDs in tile memory). The P-buffer's visible set is collected
    // this way (VisibleSetCollector) while the tiles are still in cache.
    TileIdVisitor* tileIds = nullptr;
};

// Caller-owned targets. All three views must have the same size as the camera's image. The colour
// view may be empty (data == nullptr) to render depth and IDs only. The depth and ID views may be
// empty in a colour-only render (RenderOptions::colorOnly), and each of them in a depth-tested
// render that clears its targets: the depth test and the IDs then live in the renderer's tile
// memory only and are dropped after each tile (VisibilityOutputs::tileIds still sees each tile's
// IDs), as a GPU discards a depth buffer nobody reads. A stereo pair's eyes are displayed as
// colour alone, and not writing their depth and IDs makes a P-buffer second eye faster
// (docs/stereo-results.md: 1.057 -> 0.891 ms at 1M triangles).
struct RenderTargets {
    ImageView<Rgba8> color;
    ImageView<float> depth;        // 1/w, see Conventions; 0 = cleared
    ImageView<uint32_t> id;        // global triangle index + 1; 0 = cleared
    VisibilityOutputs visibility;  // the P-buffer consumers' extras; empty by default
};

struct RenderOptions {
    Shading shading = Shading::kFlat;
    bool cullBackFaces = false;  // counter-clockwise triangles (as seen) are front faces
    bool clearTargets = true;    // clear colour, depth and ID before drawing
    // Colour only: no depth test, and the depth and ID targets are neither cleared nor written
    // (their views may be empty). Triangles are drawn in submission order, a later one
    // overwriting an earlier one where both cover a sample, so the colour equals that of the
    // depth-tested render only when no two triangles cover the same sample (a flat warp mesh
    // that does not fold, say). Preconditions: a colour target and no visibility outputs
    // (RenderTargets::visibility; see checkRenderRequest).
    bool colorOnly = false;
    // With clearTargets: clear only the tiles this Renderer drew into in its last frame on the
    // same targets (same views, size, clear colour and colorOnly) plus the tiles this frame
    // draws into; every other tile still holds the clear values. Where no such last frame is
    // known (first frame, other targets, a frame drawn without this option) the whole targets
    // are cleared. The image is the same as with a whole clear. Precondition: between frames,
    // nothing but this Renderer writes to the targets.
    bool clearDrawnTilesOnly = false;
    Rgba8 clearColor{40, 44, 52, 255};
    Vec3 lightDir{0.35f, 0.85f, 0.4f};  // towards the light, world space (normalised internally)
    float ambient = 0.25f;              // linear, added to the Lambert term
    // false: no lighting, colour = material base colour (times the texture when textured). Image
    // re-projection passes (display predistortion, warping) render this way.
    bool lit = true;
};

struct RenderStats {
    uint64_t trianglesSubmitted = 0;  // triangles considered
    uint64_t trianglesClipped = 0;    // triangles that crossed a clip plane
    uint64_t trianglesBinned = 0;     // triangles (after clipping) that reached the tiles
    // Triangle-tile pairs skipped before setup because the depth already in the tile's 8x8
    // blocks hides them (coarse occlusion culling; the images are the same without it).
    uint64_t tilePairsOccluded = 0;
    uint64_t tilesCleared = 0;  // screen tiles whose targets were cleared
    double milliseconds = 0.0;
};

struct RendererConfig {
    int threads = 0;     // 0: all hardware threads
    // Pixels per tile side, a power of two in [8, 256]. 128 by measurement (docs/raster-
    // performance.md): against 64, fewer triangles straddle tiles and are set up twice (office:64
    // tile stage 246M -> 211M instructions, the x16 helmet 246M -> 241M); 256 leaves too few
    // tiles to balance two threads on a centred model.
    int tileSize = 128;
};

// The tiled multithreaded renderer. Keeps its scratch memory between frames, so rendering
// successive frames of the same size allocates nothing. One frame at a time per Renderer.
class Renderer {
public:
    static Result<std::unique_ptr<Renderer>> create(const RendererConfig& config = {});
    ~Renderer();

    // Renders every triangle of the scene.
    RenderStats render(const scene::Scene& scene, const Camera& camera,
                       const RenderOptions& options, const RenderTargets& targets);

    // Renders only the listed triangles (global indices, each < scene.triangleCount(), in the
    // order given; duplicates are drawn twice). Cost is proportional to the list, not the scene.
    RenderStats renderSubset(const scene::Scene& scene, const Camera& camera,
                             std::span<const uint32_t> triangleIndices,
                             const RenderOptions& options, const RenderTargets& targets);

    int threadCount() const;

private:
    struct Impl;
    explicit Renderer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// Checks that options and targets fit together (a known shading, sizes against the camera's,
// the second layer complete, colorOnly's and the visibility outputs' preconditions, depth or IDs
// left out only where tile memory can stand in for them, row strides at least the width); the
// message names the first problem.
// Renderer::render, renderSubset and renderReference abort with that message on a failed check.
Status checkRenderRequest(const Camera& camera, const RenderOptions& options,
                          const RenderTargets& targets);

// Scalar reference renderer: the same arithmetic, one triangle after another, no tiles or threads.
// subset == nullptr renders every triangle.
void renderReference(const scene::Scene& scene, const Camera& camera, const RenderOptions& options,
                     const RenderTargets& targets, std::span<const uint32_t>* subset = nullptr);

// Owning colour + depth + ID images of one size, for callers that do not bring their own.
struct FrameBuffers {
    Image<Rgba8> color;
    Image<float> depth;
    Image<uint32_t> id;

    void resize(int width, int height);
    RenderTargets targets() { return {color.view(), depth.view(), id.view(), {}}; }
};

// Number of distinct non-zero IDs in an ID target (the visible triangles).
size_t countDistinctIds(const Image<uint32_t>& ids);

// Depth target as grey: near is bright, cleared pixels black. Scales between the nearest and
// farthest drawn values.
Image<Rgba8> visualizeDepth(const Image<float>& depth);
// ID target in false colour: each ID gets a stable pseudo-random colour, 0 is black.
Image<Rgba8> visualizeIds(const Image<uint32_t>& ids);

}  // namespace plx::raster
