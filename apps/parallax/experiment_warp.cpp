// The latency experiment of Mark, Bishop, McMillan, simulated: a client on a 60 Hz display asks
// a render server for reference images of its pose every refreshMs; each answer arrives one RTT
// after its request. At every display frame the newest arrived answer is shown stale, rotation-
// timewarped, or warped (one set, two sets, two sets requested for predicted poses), and each
// is compared with the render at the pose of that moment. Time is simulated, so the images and
// the PSNR figures are deterministic; only the warp times are measured.

#include "experiment_warp.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <tuple>

#include <fmt/format.h>

#include <plx/raster/raster.h>
#include <plx/scene/import.h>
#include <plx/stereo/path.h>

#include "cli.h"
#include "report.h"
#include "view.h"

namespace plx::cli {

const char* latencyMethodName(LatencyMethod method) {
    switch (method) {
        case LatencyMethod::kStale:
            return "stale";
        case LatencyMethod::kTimewarp:
            return "timewarp";
        case LatencyMethod::kWarp1:
            return "warp1";
        case LatencyMethod::kWarp2:
            return "warp2";
        case LatencyMethod::kWarp2Predicted:
            return "warp2_predicted";
        case LatencyMethod::kWarp2Bracketed:
            return "warp2_bracketed";
    }
    return "?";
}

int64_t referencePixels(const warp::ReferenceSet& set) {
    int64_t n = 0;
    for (const warp::ReferenceView& v : set.views) n += int64_t(v.color.pixelCount());
    return n;
}

Result<int64_t> referencePixels(const warp::ReferenceSetOptions& options) {
    auto views = warp::referenceCameras(warp::Pose{}, options);
    if (!views) return views.status();
    int64_t n = 0;
    for (const Camera& view : *views) n += int64_t(view.width()) * view.height();
    return n;
}

Result<Camera> displayOfSize(int width, int height) {
    CameraDesc desc;
    desc.width = width;
    desc.height = height;
    return Camera::create(desc);
}

warp::Pose poseOf(const Camera& camera) {
    return {camera.eyePos(), camera.forwardDir(), camera.upDir()};
}

warp::ReferenceSetOptions referenceOptionsFor(const scene::Scene& scene, const Camera& display,
                                              warp::ReferenceLayout layout) {
    warp::ReferenceSetOptions o = referenceDensityFor(display, layout);
    scene::clipPlanesFor(scene.bounds(), display.eyePos(), &o.nearPlane, &o.farPlane);
    return o;
}

warp::ReferenceSetOptions referenceDensityFor(const Camera& display, warp::ReferenceLayout layout) {
    warp::ReferenceSetOptions o;
    o.layout = layout;
    const float tanHalf = std::tan(radians(display.desc().fovYDegrees) * 0.5f);
    // A 90-degree cube face of side S has focal length S / 2 pixels; the display's is
    // H / (2 tan(fov / 2)). Equal densities: S = H / tan(fov / 2) (416 for 240 rows at 60 deg).
    int side = int(std::lround(float(display.height()) / tanHalf));
    // The same parity as the display's rows: both images then have their centre on a pixel
    // corner (or both on a pixel centre), so at equal density a warp to the set's own pose maps
    // pixel centres onto pixel centres. Otherwise every pixel lands half a pixel off and the
    // splats pick one of two neighbours (24 dB instead of 37 at 96x72 with 125-pixel faces).
    if ((side - display.height()) % 2 != 0)
        side += float(display.height()) / tanHalf > float(side) ? 1 : -1;
    if (layout == warp::ReferenceLayout::kWide) {
        // 20 degrees of margin each way for head turns between references, at the same density.
        o.wideFovDegrees = std::min(display.desc().fovYDegrees + 40.0f, 160.0f);
        o.wideAspect = float(display.width()) / float(display.height());
        side = int(std::lround(float(display.height()) *
                               std::tan(radians(o.wideFovDegrees) * 0.5f) / tanHalf));
    }
    o.faceSize = std::clamp(side, 1, Camera::kMaxImageSide);
    return o;
}

namespace {

constexpr double kPathHz = 30.0;          // builtinWalk's pose rate
constexpr double kArrivalSlackMs = 0.01;  // far below a frame; above a typed refresh's rounding

double cappedPsnr(const Image<Rgba8>& a, const Image<Rgba8>& b) {
    return std::min(psnr(a, b), kIdenticalPsnrDb);
}

// A camera path sampled at kPathHz and linearly interpolated between samples; times before the
// start or past the end hold the first or last pose.
class CameraPath {
public:
    explicit CameraPath(std::vector<stereo::Pose> keys) : mKeys(std::move(keys)) {}

    scene::Viewpoint at(double ms) const {
        double u = std::clamp(ms * kPathHz / 1000.0, 0.0, double(mKeys.size() - 1));
        size_t i = std::min(size_t(u), mKeys.size() - 1);
        size_t j = std::min(i + 1, mKeys.size() - 1);
        float f = float(u - double(i));
        const stereo::Pose &a = mKeys[i], &b = mKeys[j];
        return {"path", glm::mix(a.eyePos, b.eyePos, f), glm::mix(a.targetPos, b.targetPos, f),
                a.upDir, a.fovYDegrees};
    }

private:
    std::vector<stereo::Pose> mKeys;
};

// An orbit around a model (a walk would go through it): 20 degrees a second around the bounds'
// centre, breathing in and out by 10% of the radius so that the eye translates along the view
// as well as across it.
std::vector<stereo::Pose> orbitPath(const scene::Scene& scene, int frames) {
    scene::Viewpoint start = scene::defaultViewpoint(scene);
    Vec3 center = scene.bounds().center();
    Vec3 offset = start.eyePos - center;
    float radius = std::max(glm::length(Vec3(offset.x, 0.0f, offset.z)), 1e-3f);
    float angle0 = std::atan2(offset.z, offset.x);
    std::vector<stereo::Pose> poses;
    for (int i = 0; i < frames; ++i) {
        float t = float(i) / float(kPathHz);
        float angle = angle0 + radians(20.0f) * t;
        float r = radius * (1.0f + 0.1f * std::sin(1.3f * t));
        stereo::Pose p;
        p.eyePos = center + Vec3(r * std::cos(angle), offset.y, r * std::sin(angle));
        p.targetPos = center;
        p.fovYDegrees = start.fovYDegrees;
        poses.push_back(p);
    }
    return poses;
}

// Constant-velocity prediction (Mark, Bishop, McMillan, "Prediction techniques"): eye and view
// direction extrapolated `aheadMs` from their change over the last display frame.
scene::Viewpoint predict(const scene::Viewpoint& now, const scene::Viewpoint& before,
                         double frameMs, double aheadMs) {
    const float k = float(aheadMs / frameMs);
    scene::Viewpoint p = now;
    p.eyePos = now.eyePos + (now.eyePos - before.eyePos) * k;
    Vec3 dir = glm::normalize(now.targetPos - now.eyePos);
    Vec3 dirBefore = glm::normalize(before.targetPos - before.eyePos);
    Vec3 dirAhead = dir + (dir - dirBefore) * k;
    if (glm::length(dirAhead) < 1e-6f) dirAhead = dir;
    p.targetPos = p.eyePos + glm::normalize(dirAhead) * glm::length(now.targetPos - now.eyePos);
    return p;
}

struct Samples {
    std::vector<double> psnr, holes, ms;
};

// What the server sent for one request: the reference set and the display-sized frame.
struct Answer {
    warp::ReferenceSet set;
    warp::ReferenceView frame;
};

// One scene's simulation. Answers are rendered when first needed and dropped once no later
// display frame can use them.
class LatencySimulation {
public:
    LatencySimulation(const scene::Scene& scene, const CameraPath& path,
                      const WarpExperimentConfig& config, raster::Renderer& renderer,
                      warp::Warper& warper)
        : mScene(scene), mPath(path), mConfig(config), mRenderer(renderer), mWarper(warper) {}

    Status run(const std::function<void()>& frameDone);
    // Keeps every method's image of the last frame (for the first RTT) in `example`.
    void captureLastFrame(LatencyExample* example) { mExample = example; }
    const Samples& samples(size_t rtt, LatencyMethod m) const {
        return mSamples.at({rtt, size_t(m)});
    }

private:
    Result<Camera> camera(const scene::Viewpoint& vp) const {
        return scene::cameraAt(mScene, vp, mConfig.width, mConfig.height);
    }
    double frameMs() const { return 1000.0 / mConfig.displayHz; }
    // The newest request whose answer has arrived at tMs for RTT j: r_k + RTT <= t, where an
    // answer due within kArrivalSlackMs after t counts (a refresh typed as 16.6667 ms then lines
    // up with the 60 Hz frames instead of always missing them by a rounding error).
    int64_t newestArrived(double tMs, size_t j) const {
        return int64_t(std::floor((tMs - mConfig.rttsMs[j] + kArrivalSlackMs) / mConfig.refreshMs));
    }
    void dropAnswersPast(double tMs);
    Status renderAnswer(const scene::Viewpoint& vp, bool withFrame, Answer* out);
    Result<const Answer*> answer(int64_t k);
    // The set for request k's pose predicted RTT + `refreshes` refresh intervals ahead.
    Result<const Answer*> predictedAnswer(int64_t k, size_t rtt, int refreshes = 0);
    Status measureFrame(double tMs, const Camera& now, const Image<Rgba8>& truth, bool capture);
    void add(size_t rtt, LatencyMethod m, double psnrDb, double holes, double ms,
             const Image<Rgba8>* image = nullptr) {
        if (image && rtt == 0) mExample->images.push_back({m, *image, psnrDb, holes});
        Samples& s = mSamples[{rtt, size_t(m)}];
        s.psnr.push_back(psnrDb);
        s.holes.push_back(holes);
        s.ms.push_back(ms);
    }

    const scene::Scene& mScene;
    const CameraPath& mPath;
    const WarpExperimentConfig& mConfig;
    raster::Renderer& mRenderer;
    warp::Warper& mWarper;
    raster::FrameBuffers mFb;
    warp::WarpFrame mWarped;
    Image<Rgba8> mTimewarped;
    std::map<int64_t, Answer> mAnswers;
    std::map<std::tuple<int64_t, size_t, int>, Answer> mPredicted;
    std::map<std::pair<size_t, size_t>, Samples> mSamples;
    LatencyExample* mExample = nullptr;
};

Status LatencySimulation::renderAnswer(const scene::Viewpoint& vp, bool withFrame, Answer* out) {
    auto cam = camera(vp);
    if (!cam) return cam.status();
    PLX_RETURN_IF_ERROR(warp::renderReferenceSet(mRenderer, mScene, poseOf(*cam),
                                                 referenceOptionsFor(mScene, *cam, mConfig.layout),
                                                 &out->set));
    if (withFrame) {
        mFb.resize(cam->width(), cam->height());
        mRenderer.render(mScene, *cam, {}, mFb.targets());
        out->frame.camera = *cam;
        out->frame.color = mFb.color;
    }
    return Status::ok();
}

Result<const Answer*> LatencySimulation::answer(int64_t k) {
    auto it = mAnswers.find(k);
    if (it != mAnswers.end()) return &it->second;
    Answer& a = mAnswers[k];
    PLX_RETURN_IF_ERROR(renderAnswer(mPath.at(double(k) * mConfig.refreshMs), true, &a));
    return &a;
}

Result<const Answer*> LatencySimulation::predictedAnswer(int64_t k, size_t rtt, int refreshes) {
    auto it = mPredicted.find({k, rtt, refreshes});
    if (it != mPredicted.end()) return &it->second;
    const double requestMs = double(k) * mConfig.refreshMs;
    scene::Viewpoint vp = predict(mPath.at(requestMs), mPath.at(requestMs - frameMs()), frameMs(),
                                  mConfig.rttsMs[rtt] + double(refreshes) * mConfig.refreshMs);
    Answer& a = mPredicted[{k, rtt, refreshes}];
    PLX_RETURN_IF_ERROR(renderAnswer(vp, false, &a));
    return &a;
}

Status LatencySimulation::measureFrame(double tMs, const Camera& now, const Image<Rgba8>& truth,
                                       bool capture) {
    auto kept = [capture](const Image<Rgba8>& image) { return capture ? &image : nullptr; };
    const double pixels = double(now.width()) * double(now.height());
    warp::WarpOptions options;
    options.splat = mConfig.splat;
    options.compositeTolerance = mConfig.compositeTolerance;
    auto warpAndAdd = [&](size_t rtt, LatencyMethod m,
                          std::vector<const warp::ReferenceSet*> sets) {
        warp::WarpStats stats;
        Stopwatch clock;
        PLX_RETURN_IF_ERROR(mWarper.warp(sets, now, options, &mWarped, &stats));
        double ms = clock.elapsedMs();
        add(rtt, m, cappedPsnr(mWarped.color, truth), double(stats.holePixels) / pixels, ms,
            kept(mWarped.color));
        return Status::ok();
    };
    for (size_t j = 0; j < mConfig.rttsMs.size(); ++j) {
        const int64_t k = newestArrived(tMs, j);
        auto newest = answer(k);
        if (!newest) return newest.status();
        auto older = answer(k - 1);
        if (!older) return older.status();
        add(j, LatencyMethod::kStale, cappedPsnr((*newest)->frame.color, truth), 0.0, 0.0,
            kept((*newest)->frame.color));
        // Timewarp with a transparent clear colour marks the pixels with no source (every
        // rendered pixel is opaque); they are then painted the clear colour.
        const Rgba8 clear = options.clearColor, marker{0, 0, 0, 0};
        Stopwatch clock;
        PLX_RETURN_IF_ERROR(warp::rotationTimewarp((*newest)->frame, now, marker, &mTimewarped));
        double ms = clock.elapsedMs();
        int64_t holes = 0;
        for (Rgba8& p : std::span(mTimewarped.data(), mTimewarped.pixelCount()))
            if (p.a == 0) p = clear, ++holes;
        add(j, LatencyMethod::kTimewarp, cappedPsnr(mTimewarped, truth), double(holes) / pixels, ms,
            kept(mTimewarped));
        PLX_RETURN_IF_ERROR(warpAndAdd(j, LatencyMethod::kWarp1, {&(*newest)->set}));
        PLX_RETURN_IF_ERROR(
            warpAndAdd(j, LatencyMethod::kWarp2, {&(*newest)->set, &(*older)->set}));
        auto pNewest = predictedAnswer(k, j);
        if (!pNewest) return pNewest.status();
        auto pOlder = predictedAnswer(k - 1, j);
        if (!pOlder) return pOlder.status();
        PLX_RETURN_IF_ERROR(
            warpAndAdd(j, LatencyMethod::kWarp2Predicted, {&(*pNewest)->set, &(*pOlder)->set}));
        // "These viewpoints might be chosen to bracket the estimated future position of the
        // user" (Mark, Bishop, McMillan, "Improving Quality of Final Images"): request k's
        // second set is predicted one refresh past its first, where request k + 1 takes over.
        auto pNext = predictedAnswer(k, j, 1);
        if (!pNext) return pNext.status();
        PLX_RETURN_IF_ERROR(
            warpAndAdd(j, LatencyMethod::kWarp2Bracketed, {&(*pNewest)->set, &(*pNext)->set}));
    }
    return Status::ok();
}

// Later frames never need an answer older than the second newest of its RTT (newestArrived
// never decreases): a predicted set serves its own RTT alone, a plain answer every RTT, so the
// longest RTT keeps it. (Predicted sets kept for the longest RTT too would hold up to 80 sets at
// the default RTTs, where 42 serve.)
void LatencySimulation::dropAnswersPast(double tMs) {
    int64_t oldestAnswer = std::numeric_limits<int64_t>::max();
    std::vector<int64_t> oldestPredicted(mConfig.rttsMs.size());
    for (size_t j = 0; j < mConfig.rttsMs.size(); ++j) {
        oldestPredicted[j] = newestArrived(tMs, j) - 1;
        oldestAnswer = std::min(oldestAnswer, oldestPredicted[j]);
    }
    std::erase_if(mAnswers, [&](const auto& e) { return e.first < oldestAnswer; });
    std::erase_if(mPredicted, [&](const auto& e) {
        return std::get<0>(e.first) < oldestPredicted[std::get<1>(e.first)];
    });
}

Status LatencySimulation::run(const std::function<void()>& frameDone) {
    const double maxRtt = *std::max_element(mConfig.rttsMs.begin(), mConfig.rttsMs.end());
    // Lead-in: the first measured frame already has two answers of the longest RTT on a path
    // in motion.
    const double startMs = maxRtt + 2.0 * mConfig.refreshMs;
    const int frames = std::max(1, int(std::lround(mConfig.durationS * mConfig.displayHz)));
    for (int i = 0; i < frames; ++i) {
        const double tMs = startMs + double(i) * frameMs();
        auto now = camera(mPath.at(tMs));
        if (!now) return now.status();
        mFb.resize(now->width(), now->height());
        mRenderer.render(mScene, *now, {}, mFb.targets());
        Image<Rgba8> truth = mFb.color;
        const bool capture = mExample && i == frames - 1;
        if (capture) mExample->truth = truth;
        PLX_RETURN_IF_ERROR(measureFrame(tMs, *now, truth, capture));
        dropAnswersPast(tMs);
        if (frameDone) frameDone();
    }
    return Status::ok();
}

}  // namespace

// Peak bytes of a reference set's pixels (colour and 1/w), and beyond the sets those of the
// work: per set pixel (the renderer's face targets, the warp's splats; mesh splats' meshes for
// the two sets warp2 warps) and per display pixel (truth, warped and timewarped frames, the
// warp's targets). The work's shares are fitted to the peaks of the quick configuration with
// cube4 sets at 640x480 and 1280x960 (24 sets held, measured: the bound below) and with mesh
// splats on cube4 sets at 1280x720 and wide ones at 640x360 to 1280x720, and rounded up;
// MemoryCli.EstimatesHoldTheMeasuredPeak holds them to the peak.
constexpr double kSetBytesPerPixel = 8.0, kWorkPerDisplayPixel = 62.0;
double workPerSetPixel(warp::Splat splat) {
    return splat == warp::Splat::kMesh ? 32.0 : 6.0;
}

Result<double> warpExperimentBytes(const WarpExperimentConfig& c) {
    auto [minRtt, maxRtt] = std::minmax_element(c.rttsMs.begin(), c.rttsMs.end());
    // Plain answers from the longest RTT's second newest to the shortest RTT's newest, and the
    // one rendered before the frame's drop, but no more than the walk requests: per RTT, from the
    // second newest at its first frame to the newest at its last. Per RTT at most six predicted
    // sets (dropAnswersPast).
    const double rtts = double(c.rttsMs.size());
    const double answers = std::min(std::ceil((*maxRtt - *minRtt) / c.refreshMs) + 3.0,
                                    rtts * (std::ceil(c.durationS * 1000.0 / c.refreshMs) + 3.0));
    const double sets = answers + 6.0 * rtts;
    auto display = displayOfSize(c.width, c.height);
    if (!display) return display.status();
    auto latencyPixels = referencePixels(referenceDensityFor(*display, c.layout));
    if (!latencyPixels) return latencyPixels.status();
    const double work = workPerSetPixel(c.splat);
    // The scenes, one at a time, in the experiment's order: the walks', the throughput rows', the
    // size rows' (at the first size). The one renderer keeps what it grew to for the largest so
    // far.
    auto walkTriangles = largestGeneratedTriangles(c.scenes);
    auto throughputTriangles = largestGeneratedTriangles({c.throughputScene});
    auto sizeTriangles = largestGeneratedTriangles(c.sizeScenes);
    for (const auto* t : {&walkTriangles, &throughputTriangles, &sizeTriangles})
        if (!*t) return t->status();
    const double grownByThroughput = std::max(*walkTriangles, *throughputTriangles);
    const auto phase = [](double images, double sceneTriangles, double rendererTriangles) {
        return images + kGeneratedSceneBytesPerTriangle * sceneTriangles +
               kRenderBytesPerTriangle * rendererTriangles;
    };
    double bytes =
        phase((kSetBytesPerPixel * sets + work) * double(*latencyPixels) +
                  (4.0 * answers + kWorkPerDisplayPixel) * double(c.width) * double(c.height),
              *walkTriangles, *walkTriangles);
    for (size_t i = 0; i < c.throughputSizes.size(); ++i) {
        auto [w, h] = c.throughputSizes[i];
        auto throughputDisplay = displayOfSize(w, h);
        if (!throughputDisplay) return throughputDisplay.status();
        auto pixels = referencePixels(referenceDensityFor(*throughputDisplay, c.layout));
        if (!pixels) return pixels.status();
        const double images = (kSetBytesPerPixel + work) * double(*pixels) +
                              kWorkPerDisplayPixel * double(w) * double(h);
        bytes = std::max(bytes, phase(images, *throughputTriangles, grownByThroughput));
        if (i == 0)
            bytes = std::max(
                bytes, phase(images, *sizeTriangles, std::max(grownByThroughput, *sizeTriangles)));
    }
    return kRenderFixedBytes + bytes;
}

Status checkWarpExperimentConfig(const WarpExperimentConfig& c) {
    auto bad = [](const std::string& what) {
        return errorStatus(ErrorCode::kInvalidArgument, "warp experiment: " + what);
    };
    if (c.rttsMs.empty()) return bad("needs at least one RTT");
    for (double r : c.rttsMs)
        if (!(r >= 0.0 && r <= 10000.0)) return bad(fmt::format("RTT {} ms outside 0 .. 10000", r));
    if (!(c.refreshMs > 0.0 && c.refreshMs <= 10000.0))
        return bad(fmt::format("refresh {} ms outside (0, 10000]", c.refreshMs));
    if (!(c.displayHz >= 1.0 && c.displayHz <= 1000.0))
        return bad(fmt::format("display rate {} Hz outside 1 .. 1000", c.displayHz));
    if (!(c.durationS > 0.0 && c.durationS <= 600.0))
        return bad(fmt::format("duration {} s outside (0, 600]", c.durationS));
    if (c.width < 1 || c.height < 1 || c.width > Camera::kMaxImageSide ||
        c.height > Camera::kMaxImageSide)
        return bad(fmt::format("size {}x{} out of range", c.width, c.height));
    for (auto [w, h] : c.throughputSizes)
        if (w < 1 || h < 1 || w > Camera::kMaxImageSide || h > Camera::kMaxImageSide)
            return bad(fmt::format("throughput size {}x{} out of range", w, h));
    if (c.throughputFrames < 1) return bad("throughput needs at least one frame");
    return Status::ok();
}

namespace {

// Samples of the path a scene is walked on: builtinWalk for generated scenes, an orbit for a
// model; long enough for the lead-in and the measured frames.
CameraPath pathFor(const scene::Scene& scene, bool isModel, const WarpExperimentConfig& c) {
    const double maxRtt = *std::max_element(c.rttsMs.begin(), c.rttsMs.end());
    const double totalMs = maxRtt + 2.0 * c.refreshMs + c.durationS * 1000.0 + 100.0;
    const int keys = int(std::ceil(totalMs * kPathHz / 1000.0)) + 2;
    return CameraPath(isModel ? orbitPath(scene, keys) : stereo::builtinWalk(scene, keys));
}

Status runLatency(const std::string& spec, bool isModel, const WarpExperimentConfig& c,
                  raster::Renderer& renderer, warp::Warper& warper,
                  const std::function<void()>& frameDone, std::vector<LatencyRow>* rows) {
    auto scene = loadSceneChecked(spec);
    if (!scene) return errorStatus(scene.status().code(), spec + ": " + scene.status().message());
    CameraPath path = pathFor(*scene, isModel, c);
    LatencySimulation sim(*scene, path, c, renderer, warper);
    PLX_RETURN_IF_ERROR(sim.run(frameDone));
    const std::string name = isModel ? std::filesystem::path(spec).filename().string() : spec;
    for (LatencyMethod m : kLatencyMethods)
        for (size_t j = 0; j < c.rttsMs.size(); ++j) {
            const Samples& s = sim.samples(j, m);
            // The stale frame is shown as rendered: no warp whose time a median could give.
            rows->push_back(
                {name, m, c.rttsMs[j], int(s.psnr.size()), median(s.psnr), median(s.holes),
                 m == LatencyMethod::kStale ? std::nullopt : std::optional<double>(median(s.ms))});
        }
    return Status::ok();
}

// One throughput row: the references of the scene's default viewpoint warped to a pose 10 cm
// forward and turned 3 degrees, the median of `frames` warps after one warm-up.
Result<ThroughputRow> measureThroughput(const scene::Scene& scene, const std::string& name,
                                        int width, int height, int threads,
                                        const WarpExperimentConfig& c, raster::Renderer& renderer) {
    auto warper = warp::Warper::create(threads);
    if (!warper) return warper.status();
    scene::Viewpoint vp = scene::defaultViewpoint(scene);
    auto from = scene::cameraAt(scene, vp, width, height);
    if (!from) return from.status();
    warp::ReferenceSet set;
    warp::ReferenceSetOptions options = referenceOptionsFor(scene, *from, c.layout);
    PLX_RETURN_IF_ERROR(warp::renderReferenceSet(renderer, scene, poseOf(*from), options, &set));
    Vec3 forward = glm::normalize(vp.targetPos - vp.eyePos);
    vp.eyePos += forward * 0.1f;
    Vec3 side = glm::normalize(glm::cross(forward, vp.upDir));
    vp.targetPos = vp.eyePos + forward + side * std::tan(radians(3.0f));
    auto to = scene::cameraAt(scene, vp, width, height);
    if (!to) return to.status();
    warp::WarpOptions wo;
    wo.splat = c.splat;
    warp::WarpFrame frame;
    warp::WarpStats stats;
    std::vector<double> ms;
    for (int f = -1; f < c.throughputFrames; ++f) {
        Stopwatch clock;
        PLX_RETURN_IF_ERROR((*warper)->warp(set, *to, wo, &frame, &stats));
        if (f >= 0) ms.push_back(clock.elapsedMs());
    }
    ThroughputRow row{name,
                      scene.triangleCount(),
                      width,
                      height,
                      (*warper)->threadCount(),
                      options.faceSize,
                      referencePixels(set),
                      stats.sourcePixels,
                      median(ms),
                      0.0};
    row.mpixPerS = row.warpMs > 0.0 ? double(row.sourcePixels) / (row.warpMs * 1e3) : 0.0;
    return row;
}

Status runThroughput(const WarpExperimentConfig& c, raster::Renderer& renderer,
                     const std::function<void()>& step, std::vector<ThroughputRow>* rows) {
    if (!c.throughputScene.empty() && !c.throughputSizes.empty()) {
        auto scene = loadSceneChecked(c.throughputScene);
        if (!scene) return scene.status();
        for (auto [w, h] : c.throughputSizes)
            for (int t : c.throughputThreads) {
                auto row = measureThroughput(*scene, c.throughputScene, w, h, t, c, renderer);
                if (!row) return row.status();
                rows->push_back(*row);
                step();
            }
    }
    if (c.throughputSizes.empty()) return Status::ok();
    auto [w, h] = c.throughputSizes.front();
    for (const std::string& spec : c.sizeScenes) {
        auto scene = loadSceneChecked(spec);
        if (!scene) return scene.status();
        auto row = measureThroughput(*scene, spec, w, h, c.threads, c, renderer);
        if (!row) return row.status();
        rows->push_back(*row);
        step();
    }
    return Status::ok();
}

}  // namespace

Result<LatencyExample> latencyExample(const std::string& spec, const WarpExperimentConfig& config,
                                      double rttMs, int frame) {
    WarpExperimentConfig c = config;
    c.rttsMs = {rttMs};
    c.durationS = double(std::max(frame, 0) + 1) / c.displayHz;
    PLX_RETURN_IF_ERROR(checkWarpExperimentConfig(c));
    auto scene = loadSceneChecked(spec);
    if (!scene) return scene.status();
    auto renderer = raster::Renderer::create({c.threads});
    if (!renderer) return renderer.status();
    auto warper = warp::Warper::create(c.threads);
    if (!warper) return warper.status();
    CameraPath path = pathFor(*scene, false, c);
    LatencyExample example;
    LatencySimulation sim(*scene, path, c, **renderer, **warper);
    sim.captureLastFrame(&example);
    PLX_RETURN_IF_ERROR(sim.run(nullptr));
    return example;
}

Result<WarpExperiment> runWarpExperiment(const WarpExperimentConfig& config,
                                         const std::function<void(size_t, size_t)>& progress) {
    PLX_RETURN_IF_ERROR(checkWarpExperimentConfig(config));
    WarpExperiment e;
    e.config = config;
    std::vector<std::pair<std::string, bool>> scenes;
    for (const std::string& s : config.scenes) scenes.emplace_back(s, false);
    if (!config.modelPath.empty()) {
        if (std::filesystem::exists(config.modelPath))
            scenes.emplace_back(config.modelPath, true);
        else
            e.notes.push_back(fmt::format("model {} not found: skipped", config.modelPath));
    }
    auto renderer = raster::Renderer::create({config.threads});
    if (!renderer) return renderer.status();
    auto warper = warp::Warper::create(config.threads);
    if (!warper) return warper.status();
    const size_t framesPerScene =
        size_t(std::max(1L, std::lround(config.durationS * config.displayHz)));
    const size_t total = scenes.size() * framesPerScene +
                         config.throughputSizes.size() * config.throughputThreads.size() +
                         config.sizeScenes.size();
    size_t done = 0;
    auto step = [&] {
        if (progress) progress(++done, total);
    };
    for (const auto& [spec, isModel] : scenes)
        PLX_RETURN_IF_ERROR(
            runLatency(spec, isModel, config, **renderer, **warper, step, &e.latency));
    PLX_RETURN_IF_ERROR(runThroughput(config, **renderer, step, &e.throughput));
    return e;
}

nlohmann::json warpExperimentJson(const WarpExperiment& e) {
    const WarpExperimentConfig& c = e.config;
    nlohmann::json doc = {{"width", c.width},
                          {"height", c.height},
                          {"display_hz", c.displayHz},
                          {"refresh_ms", c.refreshMs},
                          {"duration_s", c.durationS},
                          {"refs", warp::referenceLayoutName(c.layout)},
                          {"splat", warp::splatName(c.splat)},
                          {"composite_tolerance", shortestDecimal(c.compositeTolerance)},
                          {"rtts_ms", c.rttsMs},
                          {"rows", nlohmann::json::array()},
                          {"throughput", nlohmann::json::array()},
                          {"notes", e.notes}};
    for (const LatencyRow& r : e.latency)
        doc["rows"].push_back({{"scene", r.scene},
                               {"method", latencyMethodName(r.method)},
                               {"rtt_ms", r.rttMs},
                               {"frames", r.frames},
                               {"psnr_db_median", r.psnrDbMedian},
                               {"hole_fraction_median", r.holeFractionMedian},
                               {"warp_ms_median", valueOrNull(r.warpMsMedian)}});
    for (const ThroughputRow& r : e.throughput)
        doc["throughput"].push_back({{"scene", r.scene},
                                     {"triangles", r.triangles},
                                     {"width", r.width},
                                     {"height", r.height},
                                     {"threads", r.threads},
                                     {"face_size", r.faceSize},
                                     {"source_pixels", r.sourcePixels},
                                     {"warped_pixels", r.warpedPixels},
                                     {"warp_ms", r.warpMs},
                                     {"mpix_per_s", r.mpixPerS}});
    return doc;
}

std::string latencyCsv(const WarpExperiment& e) {
    std::string csv =
        "scene,method,rtt_ms,frames,psnr_db_median,hole_fraction_median,warp_ms_median\n";
    for (const LatencyRow& r : e.latency)
        csv += fmt::format("{},{},{:g},{},{:.2f},{:.6f},{}\n", r.scene, latencyMethodName(r.method),
                           r.rttMs, r.frames, r.psnrDbMedian, r.holeFractionMedian,
                           figureOrEmpty(r.warpMsMedian, "{:.3f}"));
    return csv;
}

std::string throughputCsv(const WarpExperiment& e) {
    std::string csv =
        "scene,triangles,width,height,threads,face_size,source_pixels,warped_pixels,warp_ms,"
        "mpix_per_s\n";
    for (const ThroughputRow& r : e.throughput)
        csv += fmt::format("{},{},{},{},{},{},{},{},{:.3f},{:.1f}\n", r.scene, r.triangles, r.width,
                           r.height, r.threads, r.faceSize, r.sourcePixels, r.warpedPixels,
                           r.warpMs, r.mpixPerS);
    return csv;
}

std::vector<std::pair<std::string, std::string>> warpPlots(const WarpExperiment& e) {
    std::vector<std::string> scenes;
    for (const LatencyRow& r : e.latency)
        if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end())
            scenes.push_back(r.scene);
    std::vector<std::pair<std::string, std::string>> plots;
    for (const std::string& s : scenes) {
        std::vector<PlotSeries> psnrSeries, holeSeries;
        for (LatencyMethod m : kLatencyMethods) {
            PlotSeries p{latencyMethodName(m), {}}, h{latencyMethodName(m), {}};
            for (const LatencyRow& r : e.latency)
                if (r.scene == s && r.method == m) {
                    p.points.emplace_back(r.rttMs, r.psnrDbMedian);
                    h.points.emplace_back(r.rttMs, 100.0 * r.holeFractionMedian);
                }
            psnrSeries.push_back(std::move(p));
            if (m != LatencyMethod::kStale) holeSeries.push_back(std::move(h));
        }
        std::string file = s;
        std::replace_if(
            file.begin(), file.end(), [](char ch) { return !std::isalnum(ch); }, '_');
        plots.emplace_back("psnr_vs_rtt_" + file + ".svg",
                           svgLinePlot({fmt::format("{}: median PSNR against round trip", s),
                                        "RTT (ms)", "PSNR (dB)", false, false},
                                       psnrSeries));
        plots.emplace_back("holes_vs_rtt_" + file + ".svg",
                           svgLinePlot({fmt::format("{}: median hole pixels", s), "RTT (ms)",
                                        "holes (% of pixels)", false, true},
                                       holeSeries));
    }
    std::map<int, PlotSeries> byThreads;
    for (const ThroughputRow& r : e.throughput) {
        if (r.scene != e.config.throughputScene) continue;
        PlotSeries& s = byThreads[r.threads];
        s.name = fmt::format("{} thread{}", r.threads, r.threads == 1 ? "" : "s");
        s.points.emplace_back(double(r.width) * double(r.height), r.mpixPerS);
    }
    std::vector<PlotSeries> series;
    for (auto& [t, s] : byThreads) series.push_back(std::move(s));
    if (!series.empty())
        plots.emplace_back("throughput.svg",
                           svgLinePlot({"Warp throughput (source pixels per second)",
                                        "output pixels (log scale)", "Mpix/s", true, true},
                                       series));
    return plots;
}

}  // namespace plx::cli
