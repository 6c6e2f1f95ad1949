// Stereo pair rendering: the full and P-buffer methods of Heo, Jung, Wohn, the conservative
// extension, and the reproject method of Fu, Bao, Peng (reproject_pair.cpp).

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include <plx/stereo/stereo.h>

#include "conservative.h"
#include "reproject_pair.h"

namespace plx::stereo {

Result<Method> parseMethod(const std::string& name) {
    if (name == "full") return Method::kFull;
    if (name == "pbuffer") return Method::kPBuffer;
    if (name == "reproject") return Method::kReproject;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown stereo method '{}' (full, pbuffer, reproject)", name));
}

const char* methodName(Method method) {
    switch (method) {
        case Method::kFull:
            return "full";
        case Method::kPBuffer:
            return "pbuffer";
        case Method::kReproject:
            return "reproject";
    }
    return "unknown";
}

Result<FillSearch> parseFillSearch(const std::string& name) {
    if (name == "boxes") return FillSearch::kBoxHierarchy;
    if (name == "bsp") return FillSearch::kBspOrder;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown fill search '{}' (boxes, bsp)", name));
}

const char* fillSearchName(FillSearch search) {
    return search == FillSearch::kBspOrder ? "bsp" : "boxes";
}

// Screen tiles of 128 pixels for both methods. The P-buffer's second eye draws about a
// thousand mostly large polygons over the whole image: with 64-pixel tiles each reaches several
// tiles and is set up, and its rows started, once per tile; 128-pixel tiles cut the subset
// render's CPU time by about 15% (BM_SecondEyeSubset, one thread), while full renders of the
// office cost the same with either size (BM_FirstEyeWithVisibleSet).
constexpr int kStereoTileSize = 128;

struct StereoRenderer::Impl {
    std::unique_ptr<raster::Renderer> renderer;
    raster::VisibleSetCollector collector;
    ConservativeScratch conservative;
    std::vector<uint32_t> lastSet;
    std::unique_ptr<ReprojectPair> reproject;  // made by prepareReprojection

    void renderFull(const scene::Scene& scene, const StereoRig& rig, const StereoOptions& options,
                    StereoFrame* frame, StereoFrameStats* stats);
    void renderPBuffer(const scene::Scene& scene, const StereoRig& rig,
                       const StereoOptions& options, StereoFrame* frame, StereoFrameStats* stats);
};

Result<std::unique_ptr<StereoRenderer>> StereoRenderer::create(const StereoRendererConfig& config) {
    auto renderer = raster::Renderer::create({config.threads, kStereoTileSize});
    if (!renderer) return renderer.status();
    auto impl = std::make_unique<Impl>();
    impl->renderer = std::move(renderer).value();
    return std::unique_ptr<StereoRenderer>(new StereoRenderer(std::move(impl)));
}

StereoRenderer::StereoRenderer(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
StereoRenderer::~StereoRenderer() = default;
std::span<const uint32_t> StereoRenderer::lastVisibleSet() const { return mImpl->lastSet; }
raster::Renderer& StereoRenderer::renderer() { return *mImpl->renderer; }

Status StereoRenderer::prepareReprojection(const scene::Scene& scene, FillSearch search) {
    if (!mImpl->reproject)
        mImpl->reproject = std::make_unique<ReprojectPair>(mImpl->renderer->threadCount());
    return mImpl->reproject->prepare(scene, search);
}

double StereoRenderer::lastPrepareMs() const {
    return mImpl->reproject ? mImpl->reproject->lastPrepareMs() : 0.0;
}

namespace {

// Sizes an eye's images for the camera: the colour always, depth and IDs when `planes` (else
// they are released, so that no earlier frame's planes pass for this one's).
void prepareEye(const Camera& cam, bool planes, raster::FrameBuffers* eye) {
    auto fits = [&](const auto& image) {
        return image.width() == cam.width() && image.height() == cam.height();
    };
    if (!fits(eye->color)) eye->color.resize(cam.width(), cam.height());
    if (!planes) {
        eye->depth = {};
        eye->id = {};
    } else if (!fits(eye->depth) || !fits(eye->id)) {
        eye->depth.resize(cam.width(), cam.height());
        eye->id.resize(cam.width(), cam.height());
    }
}

raster::RenderTargets eyeTargets(raster::FrameBuffers& eye) {
    raster::RenderTargets t = eye.targets();
    if (eye.depth.empty()) t.depth = {};
    if (eye.id.empty()) t.id = {};
    return t;
}

}  // namespace

StereoFrameStats StereoRenderer::renderPair(const scene::Scene& scene, const StereoRig& rig,
                                            const StereoOptions& options, StereoFrame* frame) {
    PLX_CHECK(enumWithin(options.method, Method::kFull, Method::kReproject));
    const Camera& cam = rig.first();
    const bool conservativeFirst = options.method == Method::kPBuffer && options.conservative;
    for (Eye e : {Eye::kLeft, Eye::kRight})
        prepareEye(cam, options.writeDepthAndIds || (conservativeFirst && e == rig.desc().firstEye),
                   &frame->eye(e));
    StereoFrameStats stats;
    stats.triangles = scene.triangleCount();
    if (options.method != Method::kReproject) frame->holeClass = {};
    if (options.method == Method::kFull) {
        mImpl->renderFull(scene, rig, options, frame, &stats);
    } else if (options.method == Method::kPBuffer) {
        mImpl->renderPBuffer(scene, rig, options, frame, &stats);
    } else {
        PLX_CHECK(mImpl->reproject && mImpl->reproject->preparedFor(scene, options.fillSearch));
        mImpl->reproject->render(*mImpl->renderer, scene, rig, options, frame, &stats);
    }
    stats.pairMs = stats.firstEyeMs + stats.collectMs + stats.secondEyeMs;
    return stats;
}

void StereoRenderer::Impl::renderFull(const scene::Scene& scene, const StereoRig& rig,
                                      const StereoOptions& options, StereoFrame* frame,
                                      StereoFrameStats* stats) {
    raster::FrameBuffers& first = frame->eye(rig.desc().firstEye);
    raster::FrameBuffers& second = frame->eye(rig.secondEye());
    Stopwatch clock;
    renderer->render(scene, rig.first(), options.render, eyeTargets(first));
    stats->firstEyeMs = clock.elapsedMs();
    clock.restart();
    renderer->render(scene, rig.second(), options.render, eyeTargets(second));
    stats->secondEyeMs = clock.elapsedMs();
    stats->secondEyeTriangles = scene.triangleCount();
    // Not part of the method's cost: how many polygons the first eye sees, for the tables.
    lastSet.clear();
    if (first.id.empty()) return;
    collector.begin(scene.triangleCount());
    collector.add(first.id);
    stats->visibleTriangles = collector.size();
}

void StereoRenderer::Impl::renderPBuffer(const scene::Scene& scene, const StereoRig& rig,
                                         const StereoOptions& options, StereoFrame* frame,
                                         StereoFrameStats* stats) {
    raster::FrameBuffers& first = frame->eye(rig.desc().firstEye);
    raster::FrameBuffers& second = frame->eye(rig.secondEye());
    Stopwatch clock;
    if (options.conservative) {
        // First eye over a guard band, with a second depth layer; then crop to the image.
        stats->guardBandPx =
            renderConservativeFirstEye(*renderer, scene, rig, options, &conservative, &first);
    } else {
        // Fig. 6, last loop (the visible flag of every polygon in the P-buffer), run inside the
        // render: each thread scans the tiles it has just drawn, while they are in its cache.
        collector.begin(scene.triangleCount(), renderer->threadCount());
        raster::RenderTargets targets = eyeTargets(first);
        targets.visibility.tileIds = &collector;
        renderer->render(scene, rig.first(), options.render, targets);
    }
    stats->firstEyeMs = clock.elapsedMs();

    clock.restart();
    if (options.conservative) {  // the first eye's targets were cropped from a wider render
        collector.begin(scene.triangleCount());
        collector.add(first.id);
    }
    stats->visibleTriangles = collector.size();
    if (options.conservative) addConservativePolygons(conservative, &collector);
    stats->conservativeExtra = collector.size() - stats->visibleTriangles;
    const std::vector<uint32_t>& set = collector.sorted();
    stats->collectMs = clock.elapsedMs();

    clock.restart();
    renderer->renderSubset(scene, rig.second(), set, options.render, eyeTargets(second));
    stats->secondEyeMs = clock.elapsedMs();
    stats->secondEyeTriangles = set.size();
    lastSet.assign(set.begin(), set.end());
}

SecondEyeQuality compareSecondEye(const raster::FrameBuffers& approx,
                                  const raster::FrameBuffers& full,
                                  std::span<const uint32_t> drawn) {
    PLX_CHECK(!approx.id.empty() && approx.id.width() == full.id.width() &&
              approx.id.height() == full.id.height());
    SecondEyeQuality q;
    ImageDiffStats d = compareImages(approx.color, full.color, 0);
    q.psnrDb = d.psnrDb;
    q.differingPixels = d.differingPixels;
    q.differingFraction = double(d.differingPixels) / double(std::max<size_t>(1, full.color.pixelCount()));
    std::vector<uint32_t> seen;
    for (size_t i = 0; i < full.id.pixelCount(); ++i) {
        uint32_t id = full.id.data()[i];
        if (id != approx.id.data()[i]) ++q.missedPixels;
        if (id) seen.push_back(id - 1);
    }
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    for (uint32_t t : seen)
        if (!std::binary_search(drawn.begin(), drawn.end(), t)) ++q.missedPolygons;
    return q;
}

}  // namespace plx::stereo
