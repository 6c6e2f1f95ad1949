// The reproject method's frame (Fu, Bao, Peng, the algorithm sketch): render the first eye with
// depth and IDs, move its pixels into the second eye, find and classify the holes, fill them.

#include "reproject_pair.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <plx/core/timing.h>

namespace plx::stereo {

ReprojectPair::SceneKey ReprojectPair::keyOf(const scene::Scene& scene) {
    SceneKey key;
    key.address = &scene;
    key.triangles = scene.triangleCount();
    // A cheap fingerprint of the content: the same object refilled with other geometry of the
    // same size most likely moves its first or last vertex.
    if (!scene.meshes.empty() && !scene.meshes.front().positions.empty())
        key.firstVertex = scene.meshes.front().positions.front();
    if (!scene.meshes.empty() && !scene.meshes.back().positions.empty())
        key.lastVertex = scene.meshes.back().positions.back();
    return key;
}

bool ReprojectPair::preparedFor(const scene::Scene& scene, FillSearch search) const {
    return mKey && *mKey == keyOf(scene) && mFill.serves(search);
}

Status ReprojectPair::prepare(const scene::Scene& scene, FillSearch search) {
    if (preparedFor(scene, search)) return Status();
    Stopwatch clock;
    mKey.reset();
    mFill = FillScene{};  // the previous scene's structures go before the new ones are built
    auto fill = buildFillScene(scene, search, {}, {}, &mPool);
    if (!fill) return fill.status();
    mFill = std::move(fill).value();
    mKey = keyOf(scene);
    mPrepareMs = clock.elapsedMs();
    return Status();
}

const OffsetLut& ReprojectPair::lutFor(const DisparityLine& line, const Camera& camera) {
    // The nearest 1/w a render can hold is that of the near plane. Fitted near planes are close
    // (scene::clipPlanesFor: far / 20000), so the table gets as many entries as keep its error
    // (OffsetLut::maxErrorPx) to 1/32 pixel, between the default 4096 and 2^20 entries (4 MiB,
    // where the error of a 1280-pixel-wide view with a 1 mm near plane is still 0.02 pixel).
    const float maxInvW = 1.0f / camera.desc().nearPlane;
    if (!mLut || mLutLine.perInvW != line.perInvW || mLutLine.offsetPx != line.offsetPx ||
        mLutMaxInvW != maxInvW) {
        double needed = std::fabs(double(line.perInvW)) * double(maxInvW) * 16.0 + 1.0;
        int entries = int(std::clamp(needed, 4096.0, double(1 << 20)));
        auto lut = OffsetLut::create(line, maxInvW, entries);
        PLX_CHECK(lut.isOk());
        mLut = std::move(lut).value();
        mLutLine = line;
        mLutMaxInvW = maxInvW;
    }
    return *mLut;
}

namespace {

// An eye's targets with depth and IDs, taken from `planes` where the frame has none.
raster::RenderTargets withPlanes(raster::FrameBuffers& eye, raster::FrameBuffers* planes) {
    raster::RenderTargets t = eye.targets();
    if (eye.depth.empty() || eye.id.empty()) {
        if (planes->depth.width() != eye.color.width() ||
            planes->depth.height() != eye.color.height()) {
            planes->depth.resize(eye.color.width(), eye.color.height());
            planes->id.resize(eye.color.width(), eye.color.height());
        }
        t.depth = planes->depth.view();
        t.id = planes->id.view();
    }
    return t;
}

template <class T>
ImageView<const T> readOnly(const ImageView<T>& v) {
    return {v.data, v.width, v.height, v.strideElems};
}

void countHoles(const HoleSet& holes, StereoFrameStats* stats) {
    for (const Hole& h : holes.holes) {
        if (h.holeClass == HoleClass::kExpansion)
            ++stats->expansionHoles;
        else
            ++stats->disocclusionHoles;
    }
}

}  // namespace

void ReprojectPair::render(raster::Renderer& renderer, const scene::Scene& scene,
                           const StereoRig& rig, const StereoOptions& options, StereoFrame* frame,
                           StereoFrameStats* stats) {
    PLX_CHECK(preparedFor(scene, options.fillSearch));
    const Camera& cam = rig.first();
    const int w = cam.width(), h = cam.height();
    // A colour-only pair keeps the first eye's depth and IDs in scratch planes that are dead once
    // the row pass has read them, so the second eye's scratch planes are the same planes
    // (SecondEyeTargets): its marks land in depth lines the row pass has just read.
    raster::RenderTargets first = withPlanes(frame->eye(rig.desc().firstEye), &mScratchPlanes);
    // A second eye shown as colour only keeps its depth and IDs in scratch planes, written only
    // where the hole search reads them.
    const raster::FrameBuffers& secondEye = frame->eye(rig.secondEye());
    const bool secondHasPlanes = !secondEye.depth.empty() && !secondEye.id.empty();
    raster::RenderTargets second = withPlanes(frame->eye(rig.secondEye()), &mScratchPlanes);
    // The hole classes are a per-pixel plane like depth and IDs: a colour-only pair leaves them
    // out, and its row pass and fill touch no class byte.
    ImageView<uint8_t> classes;
    if (!secondHasPlanes) {
        frame->holeClass = {};
    } else {
        if (frame->holeClass.width() != w || frame->holeClass.height() != h)
            frame->holeClass.resize(w, h);
        classes = frame->holeClass.view();
    }

    Stopwatch clock;
    raster::RenderOptions firstOptions = options.render;
    firstOptions.colorOnly = false;  // the reprojection needs the first eye's depth and IDs
    renderer.render(scene, cam, firstOptions, first);
    stats->firstEyeMs = clock.elapsedMs();

    // Fu section 2: reprojection, hole segments merged into holes; section 3: their classes.
    clock.restart();
    FirstEyeTargets from{readOnly(first.color), readOnly(first.depth), readOnly(first.id)};
    // The row pass writes its hole mask into holeClass, if kept: 0, kReprojected, where a pixel
    // landed; the fill gives each hole pixel its class.
    SecondEyeTargets to{second.color, second.depth,    second.id,
                        classes,      secondHasPlanes, &mHoleRuns};
    const DisparityLine line = disparityLine(rig);
    Status moved = options.reprojectWithLut ? reproject(from, lutFor(line, cam), to, &mPool)
                                            : reproject(from, line, to, &mPool);
    PLX_CHECK(moved.isOk());
    findHoles(mHoleRuns, HoleConnectivity::k8, mHoleScratch, mHoles);
    classifyHoles(
        readOnly(to.id), mHoles,
        [&scene](uint32_t a, uint32_t b) { return trianglesOfOneSurface(scene, a - 1, b - 1); },
        &mPool);
    stats->reprojectMs = clock.elapsedMs();

    clock.restart();
    FillOptions fillOptions;
    fillOptions.render = firstOptions;
    fillOptions.search = options.fillSearch;
    fillOptions.surroundingFirst = options.reprojectSurroundingFirst;
    FillStats filled = fillHoles(scene, mFill, rig.second(), fillOptions, mHoles, to, classes,
                                 &mFillScratch, &mPool);
    // Beyond the paper: geometry outside the first eye's view hides some landed pixels.
    raster::RenderTargets secondOut = second;
    if (!secondHasPlanes) secondOut.depth = {}, secondOut.id = {};
    UnseenStats unseen = drawUnseenOccluders(scene, mFill, cam, rig.second(), line, firstOptions,
                                             secondOut, classes, &mUnseenScratch);
    stats->fillMs = clock.elapsedMs();

    stats->secondEyeMs = stats->reprojectMs + stats->fillMs;
    stats->holePixels = mHoles.pixelCount;
    stats->expansionPixels = filled.expansionPixels;
    stats->disocclusionPixels = filled.disocclusionPixels + filled.emptyPixels;
    countHoles(mHoles, stats);
    stats->fillNodesVisited =
        options.fillSearch == FillSearch::kBspOrder ? filled.nodesVisited : filled.boxNodesTested;
    stats->fillPolygonsTested = filled.polygonsTested;
    stats->fillPolygonsDrawn = filled.polygonsDrawn;
    stats->secondEyeTriangles = filled.polygonsDrawn;
    stats->unseenPixels = unseen.pixels;
    stats->unseenTriangles = unseen.trianglesDrawn;
}

}  // namespace plx::stereo
