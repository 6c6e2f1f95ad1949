// The remote rendering experiment, over real sockets: per scene and link setting one session of
// a libs/remote Server and Client in this process (they share the machine's cores), the client
// playing a walkthrough at 60 Hz in real time. The display loop warps the newest set every frame
// (its rate and warp time are this system's); every psnrEvery-th measured frame keeps the warped
// image and the set it came from, and after the session each kept frame is compared with the
// render at its pose, next to what the two baselines would have shown from the same set:
//
// - plain video streaming: the server renders the display frame at the pose it rendered the set
//   for and the client shows the newest such frame as is (rendered here, locally, at the set's
//   pose: the same timing as the set, no codec loss: both favour the baseline);
// - rotation-only timewarp of that frame to the current pose (warp::rotationTimewarp).
//
// The baselines' bytes per frame are the display frame coded as the codec codes a view's colour
// (JPEG q90 4:2:0), with an empty disparity that adds well under 1%.

#include "experiment_remote.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>

#include <fmt/format.h>

#include <plx/core/metrics.h>
#include <plx/core/timing.h>
#include <plx/raster/raster.h>
#include <plx/remote/client.h>
#include <plx/remote/codec.h>
#include <plx/remote/server.h>
#include <plx/stereo/path.h>

#include "experiment_warp.h"
#include "cli.h"
#include "report.h"
#include "view.h"

namespace plx::cli {

const char* remoteMethodName(RemoteMethod method) {
    switch (method) {
        case RemoteMethod::kWarp:
            return "warp";
        case RemoteMethod::kVideo:
            return "video";
        case RemoteMethod::kTimewarp:
            return "timewarp";
    }
    return "?";
}

remote::PoseMessage displayPoseMessage(const std::vector<Camera>& cameras, int frame,
                                       double displayHz) {
    const int n = int(cameras.size());
    const Camera& cam = cameras[size_t(frame % n)];
    remote::PoseMessage m;
    m.timestampUs = remote::clientNowUs();
    m.pose = poseOf(cam);
    if (n > 1) {
        const int prev = std::max(0, frame % n - 1), next = std::min(n - 1, frame % n + 1);
        Vec3 v = (cameras[size_t(next)].eyePos() - cameras[size_t(prev)].eyePos()) *
                 float(displayHz / double(next - prev));
        if (std::isfinite(v.x) && glm::length(v) < 1000.0f) m.hasVelocity = true, m.velocity = v;
    }
    return m;
}

warp::ReferenceSetOptions remoteReferenceFor(const Camera& display, warp::ReferenceLayout layout) {
    warp::ReferenceSetOptions options = referenceDensityFor(display, layout);
    options.faceSize = std::clamp(options.faceSize, remote::kMinFaceSize, remote::kMaxFaceSize);
    options.faceSize = std::max(remote::maxServedFaceSize(options), remote::kMinFaceSize);
    return options;
}

namespace {

constexpr double kDisplayHz = 60.0;
constexpr double kPathHz = 30.0;     // builtinWalk's pose rate (about 1.2 m/s)
// The first set of a session includes the server's first render of the scene; a loaded machine
// can take seconds over it.
constexpr double kFirstSetWaitMs = 60000.0;

double cappedPsnr(const Image<Rgba8>& a, const Image<Rgba8>& b) {
    return std::min(psnr(a, b), kIdenticalPsnrDb);
}

// The display cameras of a walkthrough at 60 Hz: builtinWalk's 30 Hz poses, interpolated, so the
// walk has bench warp's pace whatever the display rate.
Result<std::vector<Camera>> walkCameras(const scene::Scene& scene, int frames, int width,
                                        int height) {
    const int keys = int(std::ceil(double(frames) * kPathHz / kDisplayHz)) + 2;
    const std::vector<stereo::Pose> walk = stereo::builtinWalk(scene, keys);
    std::vector<Camera> cameras;
    cameras.reserve(size_t(frames));
    for (int f = 0; f < frames; ++f) {
        const double t = double(f) * kPathHz / kDisplayHz;
        const size_t i = size_t(t);
        const float a = float(t - double(i));
        const stereo::Pose &p = walk[i], &q = walk[i + 1];
        auto cam = scene::cameraAt(scene,
                                   {"walk", glm::mix(p.eyePos, q.eyePos, a),
                                    glm::mix(p.targetPos, q.targetPos, a), p.upDir, p.fovYDegrees},
                                   width, height);
        if (!cam) return cam.status();
        cameras.push_back(*cam);
    }
    return cameras;
}

// A measured display frame kept for the PSNR pass: what it showed, and which set it warped (its
// sequence and pose, not its pixels: holding the set would keep every set of the session).
struct Kept {
    int frame = 0;
    uint32_t sequence = 0;
    warp::Pose pose;
    Image<Rgba8> warped;
};

// What a video streamer would have sent for a set: the display frame at the set's pose.
struct VideoFrame {
    warp::ReferenceView view;
    size_t bytes = 0;
};

struct SessionResult {
    std::vector<Kept> kept;
    std::vector<double> warpMs, ageMs;
    double seconds = 0.0;
    int64_t references = 0, bytes = 0;
    double rttMs = 0.0;
};

// One session: server and client over loopback with the link emulated on the server's socket,
// the walk played at 60 Hz in real time.
Result<SessionResult> playSession(const RemoteExperimentConfig& c,
                                  const std::shared_ptr<const scene::Scene>& scene,
                                  const std::vector<Camera>& cameras, const LinkSetting& link,
                                  warp::Warper& warper) {
    remote::ServerConfig sc;
    sc.port = 0;
    sc.reference = remoteReferenceFor(cameras.front(), c.layout);
    sc.maxSessions = 1;
    sc.renderThreads = c.threads;
    // "Over loopback, latency L on the server gives a round trip of 2L" (transport.h).
    sc.link.latencyMs = link.rttMs * 0.5;
    sc.link.bandwidthMbit = link.bandwidthMbit;
    auto server = remote::Server::create(scene, sc);
    if (!server) return server.status();
    remote::ClientConfig cc;
    cc.port = (*server)->port();
    cc.layout = c.layout;
    cc.faceSize = sc.reference.faceSize;
    auto client = remote::Client::create(cc);
    if (!client) return client.status();
    (*client)->setPose(displayPoseMessage(cameras, 0, kDisplayHz));
    if (!(*client)->waitForFirst(kFirstSetWaitMs))
        return errorStatus(ErrorCode::kInternal,
                           fmt::format("no reference set within {:g} s at RTT {:g} ms",
                                       kFirstSetWaitMs * 1e-3, link.rttMs));

    const int leadIn = int(std::lround(c.leadInS * kDisplayHz));
    const int frames = int(cameras.size());
    SessionResult r;
    warp::WarpFrame out;
    remote::ClientStats atStart;
    auto measureStart = std::chrono::steady_clock::now();
    const auto start = std::chrono::steady_clock::now();
    for (int f = 0; f < frames; ++f) {
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(f / kDisplayHz)));
        if (f == leadIn) {
            atStart = (*client)->stats();
            measureStart = std::chrono::steady_clock::now();
        }
        (*client)->setPose(displayPoseMessage(cameras, f, kDisplayHz));
        std::shared_ptr<const remote::ReceivedSet> ref = (*client)->newest();
        const warp::ReferenceSet* sets[] = {&ref->set};
        Stopwatch clock;
        PLX_RETURN_IF_ERROR(warper.warp(sets, cameras[size_t(f)], {}, &out));
        const double ms = clock.elapsedMs();
        if (f < leadIn) continue;
        r.warpMs.push_back(ms);
        if (ref->requestTimestampUs != 0)
            r.ageMs.push_back(double(remote::clientNowUs() - ref->requestTimestampUs) * 1e-3);
        if ((f - leadIn) % c.psnrEvery == 0)
            r.kept.push_back({f, ref->sequence, ref->set.pose, out.color});
    }
    // The measured frames span from the first one's start to when the frame after the last was
    // due (or the loop's actual end, when it fell behind): at most 60 frames/s.
    r.seconds = std::max(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - measureStart).count(),
        double(frames - leadIn) / kDisplayHz);
    const remote::ClientStats atEnd = (*client)->stats();
    (*client)->stop();
    (*server)->stop();
    r.references = atEnd.referencesReceived - atStart.referencesReceived;
    r.bytes = atEnd.bytesReceived - atStart.bytesReceived;
    if (r.references <= 0) {  // none arrived while measuring (a very slow link): the totals
        r.references = 0;
        r.bytes = atEnd.referencesReceived ? atEnd.bytesReceived / atEnd.referencesReceived : 0;
    }
    r.rttMs = atEnd.rttMs;
    return r;
}

Result<VideoFrame> videoFrameFor(const scene::Scene& scene, const Camera& display,
                                 const warp::Pose& pose, raster::Renderer& renderer) {
    auto cam = scene::cameraAt(
        scene, {"video", pose.eye, pose.eye + pose.forward, pose.up, display.desc().fovYDegrees},
        display.width(), display.height());
    if (!cam) return cam.status();
    raster::FrameBuffers fb;
    fb.resize(cam->width(), cam->height());
    renderer.render(scene, *cam, {}, fb.targets());
    VideoFrame v;
    v.view.camera = *cam;
    v.view.color = std::move(fb.color);
    v.view.disparity = Image<float>(cam->width(), cam->height(), 0.0f);
    v.view.rowMinDisparity.assign(size_t(cam->height()), 0.0f);
    v.view.rowMaxDisparity.assign(size_t(cam->height()), 0.0f);
    auto bytes = remote::encodeReferenceView(v.view, {});
    if (!bytes) return bytes.status();
    v.bytes = bytes->size();
    return v;
}

// The PSNR pass over a session's kept frames, and its rows.
Status addRows(const std::string& spec, const scene::Scene& scene,
               const std::vector<Camera>& cameras, const LinkSetting& link, const SessionResult& s,
               raster::Renderer& renderer, std::vector<RemoteRow>* rows,
               std::optional<RemoteExample>* example) {
    const size_t exampleAt = example ? s.kept.size() / 2 : s.kept.size();
    // The video frame of the set the last kept frame showed: kept frames show the sets in the
    // order they arrived, so each set's frame is rendered once and dropped when the next arrives.
    std::optional<uint32_t> videoSequence;
    VideoFrame video;
    std::vector<double> psnrs[3], timewarpMs, videoBytes;
    raster::FrameBuffers truth;
    Image<Rgba8> timewarped;
    const Rgba8 clear = warp::WarpOptions{}.clearColor, marker{0, 0, 0, 0};
    for (size_t i = 0; i < s.kept.size(); ++i) {
        const Kept& k = s.kept[i];
        const Camera& cam = cameras[size_t(k.frame)];
        truth.resize(cam.width(), cam.height());
        renderer.render(scene, cam, {}, truth.targets());
        if (videoSequence != k.sequence) {
            auto v = videoFrameFor(scene, cam, k.pose, renderer);
            if (!v) return v.status();
            videoBytes.push_back(double(v->bytes));
            video = std::move(v).value();
            videoSequence = k.sequence;
        }
        psnrs[0].push_back(cappedPsnr(k.warped, truth.color));
        psnrs[1].push_back(cappedPsnr(video.view.color, truth.color));
        // Timewarp with a transparent clear colour marks the pixels with no source; they are
        // then painted the clear colour (as bench warp does).
        Stopwatch clock;
        PLX_RETURN_IF_ERROR(warp::rotationTimewarp(video.view, cam, marker, &timewarped));
        timewarpMs.push_back(clock.elapsedMs());
        for (Rgba8& p : std::span(timewarped.data(), timewarped.pixelCount()))
            if (p.a == 0) p = clear;
        psnrs[2].push_back(cappedPsnr(timewarped, truth.color));
        if (i == exampleAt)
            *example = RemoteExample{spec,
                                     link.rttMs,
                                     k.frame,
                                     truth.color,
                                     {{RemoteMethod::kWarp, k.warped, psnrs[0].back()},
                                      {RemoteMethod::kVideo, video.view.color, psnrs[1].back()},
                                      {RemoteMethod::kTimewarp, timewarped, psnrs[2].back()}}};
    }
    const double sets = s.seconds > 0.0 ? double(s.references) / s.seconds : 0.0;
    for (RemoteMethod m : kRemoteMethods) {
        RemoteRow r;
        r.scene = spec;
        r.rttMs = link.rttMs;
        r.bandwidthMbit = link.bandwidthMbit;
        r.method = m;
        r.frames = int(s.warpMs.size());
        r.psnrFrames = int(s.kept.size());
        r.clientFps = s.seconds > 0.0 ? double(s.warpMs.size()) / s.seconds : 0.0;
        r.referencesPerS = sets;
        r.referenceAgeMsMedian = median(s.ageMs);
        r.rttMeasuredMs = s.rttMs;
        r.psnrDbMedian = median(psnrs[size_t(m)]);
        switch (m) {
            case RemoteMethod::kWarp:
                r.warpMsMedian = median(s.warpMs);
                r.bytesPerReference =
                    s.references ? double(s.bytes) / double(s.references) : double(s.bytes);
                break;
            case RemoteMethod::kVideo:
                r.bytesPerReference = median(videoBytes);
                break;
            case RemoteMethod::kTimewarp:
                r.warpMsMedian = median(timewarpMs);
                r.bytesPerReference = median(videoBytes);
                break;
        }
        rows->push_back(r);
    }
    return Status::ok();
}

}  // namespace

Status checkRemoteExperimentConfig(const RemoteExperimentConfig& c) {
    auto bad = [](const std::string& m) { return errorStatus(ErrorCode::kInvalidArgument, m); };
    if (c.scenes.empty()) return bad("no scenes");
    if (c.links.empty()) return bad("no link settings");
    for (const LinkSetting& l : c.links) {
        if (!(l.rttMs >= 0.0 && l.rttMs <= 10000.0))
            return bad(fmt::format("RTT {} ms outside 0 .. 10000", l.rttMs));
        if (!(l.bandwidthMbit >= 0.01 && l.bandwidthMbit <= 100000.0))
            return bad(fmt::format("bandwidth {} Mbit/s outside 0.01 .. 100000", l.bandwidthMbit));
    }
    if (c.width < 16 || c.height < 16 || c.width > 4096 || c.height > 4096)
        return bad(fmt::format("size {}x{} outside 16 .. 4096", c.width, c.height));
    if (!(c.leadInS >= 0.0 && c.leadInS <= 60.0))
        return bad(fmt::format("lead-in {} s outside 0 .. 60", c.leadInS));
    if (!(c.durationS >= 0.1 && c.durationS <= 600.0))
        return bad(fmt::format("duration {} s outside 0.1 .. 600", c.durationS));
    if (c.psnrEvery < 1 || c.psnrEvery > 1000)
        return bad(fmt::format("PSNR step {} outside 1 .. 1000", c.psnrEvery));
    if (c.threads < 0 || c.threads > 1024) return bad(fmt::format("threads {}", c.threads));
    return Status::ok();
}

// Bytes per reference-set pixel (the server's render targets, encoder and queued message, the
// client's decoded sets) and per display pixel beyond the kept frames (the warped frame, the
// truth and video frames of the PSNR pass): fitted to the peaks of the quick configuration at
// 512x512 and 1024x1024 (cube4, 8 and 45 kept frames), rounded up;
// MemoryCli.EstimatesHoldTheMeasuredPeak holds them to the peak.
constexpr double kSessionBytesPerSetPixel = 33.0, kSessionBytesPerDisplayPixel = 64.0;
// Beyond them and the scene, the quick configuration's peaks on office:2 to office:512 (96x72)
// exceed the fitted terms by up to 4.4 MiB (the server's and the client's threads and buffers);
// rounded up.
constexpr double kSessionFixedBytes = 6 << 20;

Result<double> remoteExperimentBytes(const RemoteExperimentConfig& c) {
    auto display = displayOfSize(c.width, c.height);
    if (!display) return display.status();
    auto setPixels = referencePixels(remoteReferenceFor(*display, c.layout));
    if (!setPixels) return setPixels.status();
    const double measured = std::lround(c.durationS * kDisplayHz);
    const double kept = std::ceil(measured / double(c.psnrEvery));
    auto triangles = largestGeneratedTriangles(c.scenes);
    if (!triangles) return triangles.status();
    const double scenes = kGeneratedSceneBytesPerTriangle * *triangles +
                          2.0 * (kRenderFixedBytes + kRenderBytesPerTriangle * *triangles);
    return kSessionFixedBytes + kSessionBytesPerSetPixel * double(*setPixels) +
           (4.0 * kept + kSessionBytesPerDisplayPixel) * double(c.width) * double(c.height) +
           scenes;
}

Result<RemoteExperiment> runRemoteExperiment(const RemoteExperimentConfig& config,
                                             const std::function<void(size_t, size_t)>& progress) {
    PLX_RETURN_IF_ERROR(checkRemoteExperimentConfig(config));
    RemoteExperiment e;
    e.config = config;
    auto renderer = raster::Renderer::create({config.threads});
    if (!renderer) return renderer.status();
    auto warper = warp::Warper::create(config.threads);
    if (!warper) return warper.status();
    const size_t total = config.scenes.size() * config.links.size();
    size_t done = 0;
    const int frames = int(std::lround((config.leadInS + config.durationS) * kDisplayHz));
    for (const std::string& spec : config.scenes) {
        auto loaded = loadSceneChecked(spec);
        if (!loaded) return loaded.status();
        // Shared with each session's server, not copied.
        const auto scene = std::make_shared<const scene::Scene>(std::move(loaded).value());
        auto cameras = walkCameras(*scene, frames, config.width, config.height);
        if (!cameras) return cameras.status();
        for (const LinkSetting& link : config.links) {
            auto s = playSession(config, scene, *cameras, link, **warper);
            if (!s) return s.status();
            const bool wantExample = !e.example && link.rttMs == config.exampleRttMs;
            PLX_RETURN_IF_ERROR(addRows(spec, *scene, *cameras, link, *s, **renderer, &e.rows,
                                        wantExample ? &e.example : nullptr));
            if (progress) progress(++done, total);
        }
    }
    e.notes.push_back(
        "server and client in one process over loopback, sharing the machine's cores; the link "
        "emulated on the server's socket (latency RTT/2 each way, bandwidth both ways)");
    e.notes.push_back(
        "client_fps is the session's display loop, which warps every frame; video needs no "
        "per-frame work and timewarp less than the warp");
    e.notes.push_back(
        "video and timewarp frames: rendered locally at the pose of the newest received set "
        "(with the server's prediction), no codec loss; their bytes: the frame as JPEG q90");
    return e;
}

double psnrGainOverVideo(const RemoteExperiment& e, const std::string& scene, double rttMs,
                         RemoteMethod method) {
    const RemoteRow *ours = nullptr, *video = nullptr;
    for (const RemoteRow& r : e.rows) {
        if (r.scene != scene || r.rttMs != rttMs) continue;
        if (r.method == method && !ours) ours = &r;
        if (r.method == RemoteMethod::kVideo && !video &&
            (!ours || ours->bandwidthMbit == r.bandwidthMbit))
            video = &r;
    }
    if (!ours || !video) return std::nan("");
    return ours->psnrDbMedian - video->psnrDbMedian;
}

nlohmann::json remoteExperimentJson(const RemoteExperiment& e) {
    const RemoteExperimentConfig& c = e.config;
    nlohmann::json doc = {{"width", c.width},
                          {"height", c.height},
                          {"display_hz", kDisplayHz},
                          {"lead_in_s", c.leadInS},
                          {"duration_s", c.durationS},
                          {"psnr_every", c.psnrEvery},
                          {"refs", warp::referenceLayoutName(c.layout)},
                          {"scenes", c.scenes},
                          {"rows", nlohmann::json::array()},
                          {"notes", e.notes}};
    for (const RemoteRow& r : e.rows)
        doc["rows"].push_back({{"scene", r.scene},
                               {"rtt_ms", r.rttMs},
                               {"bandwidth_mbit", r.bandwidthMbit},
                               {"method", remoteMethodName(r.method)},
                               {"client_fps", r.clientFps},
                               {"warp_ms_median", r.warpMsMedian},
                               {"references_per_s", r.referencesPerS},
                               {"bytes_per_reference", r.bytesPerReference},
                               {"reference_age_ms_median", r.referenceAgeMsMedian},
                               {"psnr_db_median", r.psnrDbMedian},
                               {"frames", r.frames},
                               {"psnr_frames", r.psnrFrames},
                               {"rtt_measured_ms", r.rttMeasuredMs}});
    return doc;
}

std::string remoteCsv(const RemoteExperiment& e) {
    std::string csv =
        "scene,rtt_ms,bandwidth_mbit,method,client_fps,warp_ms_median,references_per_s,"
        "bytes_per_reference,reference_age_ms_median,psnr_db_median,frames,psnr_frames,"
        "rtt_measured_ms\n";
    for (const RemoteRow& r : e.rows)
        csv += fmt::format(
            "{},{:g},{:g},{},{:.2f},{:.3f},{:.2f},{:.0f},{:.1f},{:.2f},{},{},{:.1f}\n", r.scene,
            r.rttMs, r.bandwidthMbit, remoteMethodName(r.method), r.clientFps, r.warpMsMedian,
            r.referencesPerS, r.bytesPerReference, r.referenceAgeMsMedian, r.psnrDbMedian, r.frames,
            r.psnrFrames, r.rttMeasuredMs);
    return csv;
}

std::vector<std::pair<std::string, std::string>> remotePlots(const RemoteExperiment& e) {
    std::vector<std::pair<std::string, std::string>> plots;
    const double sweepBandwidth = e.config.links.front().bandwidthMbit;
    for (const std::string& s : e.config.scenes) {
        std::string file = s;
        std::replace_if(
            file.begin(), file.end(), [](char ch) { return !std::isalnum(ch); }, '_');
        std::vector<PlotSeries> byRtt, byBandwidth;
        PlotSeries fps{"client (warps every frame)", {}};
        for (RemoteMethod m : kRemoteMethods) {
            PlotSeries p{remoteMethodName(m), {}}, b{remoteMethodName(m), {}};
            for (const RemoteRow& r : e.rows) {
                if (r.scene != s || r.method != m) continue;
                if (r.bandwidthMbit == sweepBandwidth) {
                    p.points.emplace_back(r.rttMs, r.psnrDbMedian);
                    if (m == RemoteMethod::kWarp) fps.points.emplace_back(r.rttMs, r.clientFps);
                }
                if (r.rttMs == 100.0) b.points.emplace_back(r.bandwidthMbit, r.psnrDbMedian);
            }
            std::sort(b.points.begin(), b.points.end());
            byRtt.push_back(std::move(p));
            byBandwidth.push_back(std::move(b));
        }
        plots.emplace_back(
            "psnr_vs_rtt_" + file + ".svg",
            svgLinePlot(
                {fmt::format("{}: median PSNR against round trip ({:g} Mbit/s)", s, sweepBandwidth),
                 "RTT (ms)", "PSNR (dB)", false, false},
                byRtt));
        if (byBandwidth.front().points.size() > 1)
            plots.emplace_back(
                "psnr_vs_bandwidth_" + file + ".svg",
                svgLinePlot({fmt::format("{}: median PSNR against bandwidth "
                                         "(RTT 100 ms)",
                                         s),
                             "bandwidth (Mbit/s, log scale)", "PSNR (dB)", true, false},
                            byBandwidth));
        plots.emplace_back("fps_vs_rtt_" + file + ".svg",
                           svgLinePlot({fmt::format("{}: client frames per second", s), "RTT (ms)",
                                        "frames/s", false, true},
                                       {fps}));
    }
    return plots;
}

}  // namespace plx::cli
