#pragma once
// Stereo pairs by reusing visibility (Heo, Jung, Wohn, section IV).
//
// Methods:
//  - full:    both eyes through the whole pipeline (the paper's baseline);
//  - pbuffer: the first eye is rendered with the P-buffer (polygon-ID target); the visible flag of
//             every polygon whose ID appears in it is set (Fig. 6, last loop:
//             raster::VisibleSetCollector); the second eye is rendered from the visible polygons
//             only;
//  - reproject: the first eye is rendered with depth and IDs; its pixels are moved into the
//             second eye (Fu, Bao, Peng, reproject.h), the hole segments merged into holes and
//             classified (holes.h), and only the holes are drawn: expansion holes from their one
//             polygon, disocclusion holes by the front-to-back BSP search (fill.h).
// Beyond the paper, the conservative option widens the visible set towards what the second eye
// sees and the first does not: a guard band of extra first-eye columns (polygons just outside the
// first eye's frustum), a second depth layer along depth discontinuities (polygons just behind
// foreground edges), both sized from the eye separation, and the sub-pixel polygons the first
// eye's samples fell between (see conservative.h).

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <plx/raster/raster.h>
#include <plx/raster/visible_set.h>
#include <plx/stereo/fill.h>

namespace plx::stereo {

enum class Method { kFull, kPBuffer, kReproject };
Result<Method> parseMethod(const std::string& name);
const char* methodName(Method method);
// "boxes" (FillSearch::kBoxHierarchy) and "bsp" (FillSearch::kBspOrder).
Result<FillSearch> parseFillSearch(const std::string& name);
const char* fillSearchName(FillSearch search);

struct StereoOptions {
    Method method = Method::kPBuffer;
    bool conservative = false;
    // false: each eye's depth and ID images are left empty and only its colour is written; the
    // depth test and the P-buffer's IDs stay in the renderer's tile memory (raster::
    // RenderTargets), as a GPU discards buffers nobody reads back. A display shows colour alone,
    // and the stereo experiment times both methods this way. The conservative method's first
    // eye keeps its planes (it is cropped from a wider render); the reproject method leaves
    // StereoFrame::holeClass empty too. compareSecondEye needs the planes.
    bool writeDepthAndIds = true;
    raster::RenderOptions render;
    // reproject method: the offset look-up table instead of the direct form (reproject.h).
    bool reprojectWithLut = false;
    // reproject method: the disocclusion search (fill.h); the BSP order is the paper's.
    FillSearch fillSearch = FillSearch::kBoxHierarchy;
    // reproject method: FillOptions::surroundingFirst (fill.h), faster and approximate.
    bool reprojectSurroundingFirst = false;
};

// Per second-eye pixel, how the reproject method produced it (StereoFrame::holeClass).
enum class PixelSource : uint8_t {
    kReprojected = 0,        // moved from the first eye
    kExpansion = 1,          // expansion hole, drawn from its polygon
    kDisocclusion = 2,       // disocclusion hole, drawn from the polygon the search found
    kDisocclusionEmpty = 3,  // disocclusion hole no polygon covers: clear colour, depth 0
    kUnseen = 4,  // reprojected, then hidden by geometry outside the first eye's view (unseen.h)
};

struct StereoFrameStats {
    // First eye, including the P-buffer (same pass) and, for the pbuffer method, the marking of
    // the visible polygons, done per tile inside the render.
    double firstEyeMs = 0.0;
    // The rest of the visible-set collection (pbuffer method): gathering the threads' finds and
    // sorting them; with --conservative, the pass over the cropped P-buffer and the extra sets.
    double collectMs = 0.0;
    double secondEyeMs = 0.0;  // second eye (full render, or the visible subset)
    double pairMs = 0.0;       // first + collect + second
    size_t triangles = 0;      // scene triangles
    // Distinct IDs in the first eye's P-buffer (full method: 0 when its IDs are not written).
    size_t visibleTriangles = 0;
    size_t secondEyeTriangles = 0;  // triangles submitted for the second eye
    size_t conservativeExtra = 0;   // triangles the conservative option added
    int guardBandPx = 0;            // extra first-eye columns on each side (conservative)

    // reproject method; secondEyeMs = reprojectMs + fillMs.
    double reprojectMs = 0.0;     // moving the pixels, finding and classifying the holes
    double fillMs = 0.0;          // drawing the holes, and what the first eye did not see
    int64_t holePixels = 0;       // second-eye pixels nothing landed on, or gaps (reproject.h)
    int64_t expansionPixels = 0;  // drawn from an expansion hole's polygon (PixelSource 1)
    // The rest of the hole pixels (PixelSource 2 and 3): disocclusion holes, and the pixels of
    // expansion holes their polygon does not cover, which fall through to the search.
    int64_t disocclusionPixels = 0;
    size_t expansionHoles = 0;
    size_t disocclusionHoles = 0;
    size_t fillNodesVisited = 0;    // nodes of FillSearch's tree the searches reached
    size_t fillPolygonsTested = 0;  // fragments given the separating test
    size_t fillPolygonsDrawn = 0;   // fragments whose triangle was scan-converted into a hole
    // Second-eye pixels whose nearest surface lies outside the first eye's view, in front of
    // what landed there, and the triangles drawn for them (unseen.h; part of fillMs).
    int64_t unseenPixels = 0;
    size_t unseenTriangles = 0;
};

// Colour, depth and IDs of both eyes.
struct StereoFrame {
    raster::FrameBuffers left, right;
    // reproject method with writeDepthAndIds: PixelSource of every second-eye pixel; else empty.
    Image<uint8_t> holeClass;
    raster::FrameBuffers& eye(Eye e) { return e == Eye::kLeft ? left : right; }
    const raster::FrameBuffers& eye(Eye e) const { return e == Eye::kLeft ? left : right; }
};

struct StereoRendererConfig {
    int threads = 0;  // 0: all hardware threads
};

class StereoRenderer {
public:
    static Result<std::unique_ptr<StereoRenderer>> create(const StereoRendererConfig& config = {});
    ~StereoRenderer();

    // Renders both eyes of the rig into `frame` (resized as needed) with the given method.
    // Preconditions (checked, abort): options.method among its enumerators (and, for
    // Method::kReproject, options.fillSearch); not options.render.colorOnly with
    // options.conservative (the wider first eye is cropped from its planes); for
    // Method::kReproject, prepareReprojection for this scene and options.fillSearch.
    StereoFrameStats renderPair(const scene::Scene& scene, const StereoRig& rig,
                                const StereoOptions& options, StereoFrame* frame);

    // Builds what the reproject method with `search` reuses for every view of `scene` unless
    // already built for it: the box hierarchy (scene/box_hierarchy.h), and for
    // FillSearch::kBspOrder the BSP tree (scene/bsp.h) too (buildFillScene, fill.h). renderPair
    // with Method::kReproject needs it first, for its options.fillSearch. Errors: those of
    // buildFillScene.
    Status prepareReprojection(const scene::Scene& scene,
                               FillSearch search = FillSearch::kBoxHierarchy);
    // Milliseconds the last prepareReprojection that built something took.
    double lastPrepareMs() const;

    // Triangle indices the second eye was drawn from in the last pbuffer frame (ascending).
    std::span<const uint32_t> lastVisibleSet() const;
    raster::Renderer& renderer();

private:
    struct Impl;
    explicit StereoRenderer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> mImpl;
};

// Quality of an approximate second eye against the full render of the same eye.
struct SecondEyeQuality {
    double psnrDb = 0.0;             // RGB, +infinity when identical
    double differingFraction = 0.0;  // pixels whose colour differs at all
    int64_t differingPixels = 0;
    size_t missedPolygons = 0;  // polygons visible in the full render but not drawn
    int64_t missedPixels = 0;   // pixels whose ID differs from the full render
};

// drawn: the triangle set the approximation was rendered from (sorted ascending). Preconditions
// (checked, abort): both frames have their ID images (StereoOptions::writeDepthAndIds), of one
// size.
SecondEyeQuality compareSecondEye(const raster::FrameBuffers& approx,
                                  const raster::FrameBuffers& full,
                                  std::span<const uint32_t> drawn);

}  // namespace plx::stereo
