// parallax client ws://HOST:PORT: the warping client of Mark, Bishop, McMillan's remote
// rendering system. Plays a pose path at 60 Hz in real time without a window: each display
// frame warps the newest reference set the server sent (libs/remote, client.h) to the current
// pose, so head motion never waits for the network.

#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include <plx/core/parallel.h>
#include <plx/raster/raster.h>
#include <plx/remote/client.h>
#include <plx/remote/transport.h>
#include <plx/stereo/layout.h>
#include <plx/stereo/path.h>
#include <plx/warp/warp.h>

#include "commands.h"
#include "experiment_remote.h"
#include "experiment_warp.h"
#include "view.h"

namespace plx::cli {
namespace {

constexpr double kDisplayHz = 60.0;
constexpr float kEyeSeparation = 0.065f;  // metres, as `parallax stereo`'s default

struct ClientArgs {
    std::string url;
    std::string token;
    std::string sourceAddress;
    std::string path;
    std::optional<int> walk;
    std::string size = "1280x720";
    std::string refs = "cube4";
    bool stereo = false;
    int frames = 0;  // 0: the path's length
    std::string out;
    int every = 1;
    std::string scene;
    int threads = 0;
    double waitS = 20.0;  // for the first set (a big scene's first render takes a while)
    bool json = false;
};

struct ClientPlan {
    remote::WsUrl url;
    IVec2 size{0, 0};
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;
};

Result<ClientPlan> plan(const ClientArgs& a) {
    ClientPlan p;
    auto url = remote::parseWsUrl(a.url);
    if (!url) return url.status();
    p.url = *url;
    auto size = parseSize(a.size);
    if (!size) return size.status();
    p.size = *size;
    auto layout = warp::parseReferenceLayout(a.refs);
    if (!layout) return layout.status();
    p.layout = *layout;
    auto bad = [](const std::string& m) { return errorStatus(ErrorCode::kInvalidArgument, m); };
    if (a.walk.has_value() == !a.path.empty()) return bad("give exactly one of --path and --walk");
    PLX_RETURN_IF_ERROR(checkWalk(a.walk));
    if (a.walk && a.scene.empty())
        return bad("--walk needs --scene (the walk starts at the scene's default viewpoint)");
    if (a.frames < 0 || a.frames > 1000000)
        return bad(fmt::format("--frames {} outside 1 .. 1000000", a.frames));
    if (a.every < 1 || a.every > 1000000)
        return bad(fmt::format("--every {} outside 1 .. 1000000", a.every));
    PLX_RETURN_IF_ERROR(checkThreadCount(a.threads, "--threads"));
    if (!(a.waitS > 0.0 && a.waitS <= 3600.0))
        return bad(fmt::format("--wait {} outside (0, 3600] seconds", a.waitS));
    return p;
}

// The display cameras of the path: --walk N poses of the built-in walk through --scene, or the
// --path file's poses (clip planes fitted to the scene when there is one).
Result<std::vector<Camera>> pathCameras(const ClientArgs& a, IVec2 size,
                                        const scene::Scene* scene) {
    auto loaded = walkOrPathPoses(scene, a.walk, a.path);
    if (!loaded) return loaded.status();
    const std::vector<stereo::Pose> poses = std::move(loaded).value();
    std::vector<Camera> cameras;
    for (size_t i = 0; i < poses.size(); ++i) {
        const stereo::Pose& p = poses[i];
        Result<Camera> cam = errorStatus(ErrorCode::kInternal, "unset");
        if (scene) {
            cam = scene::cameraAt(*scene, {"path", p.eyePos, p.targetPos, p.upDir, p.fovYDegrees},
                                  size.x, size.y);
        } else {
            CameraDesc d;
            d.eyePos = p.eyePos, d.targetPos = p.targetPos, d.upDir = p.upDir;
            d.fovYDegrees = p.fovYDegrees, d.width = size.x, d.height = size.y;
            cam = Camera::create(d);
        }
        if (!cam)
            return errorStatus(cam.status().code(),
                               fmt::format("pose {}: {}", i, cam.status().message()));
        cameras.push_back(*cam);
    }
    if (cameras.empty()) return errorStatus(ErrorCode::kInvalidArgument, "the path has no poses");
    return cameras;
}

struct FrameStat {
    int frame = 0;
    double warpMs = 0.0, referenceAgeMs = 0.0, psnrDb = -1.0;
    int64_t bytesReceived = 0;
    uint32_t sequence = 0;
};

std::string statsCsv(const std::vector<FrameStat>& stats) {
    std::string csv = "frame,warp_ms,reference_age_ms,bytes_received,sequence,psnr_db\n";
    for (const FrameStat& s : stats)
        csv += fmt::format("{},{:.3f},{:.1f},{},{},{}\n", s.frame, s.warpMs, s.referenceAgeMs,
                           s.bytesReceived, s.sequence,
                           s.psnrDb < 0.0 ? std::string() : fmt::format("{:.2f}", s.psnrDb));
    return csv;
}

struct LoopResult {
    std::vector<FrameStat> frames;
    double seconds = 0.0;
    int written = 0;
};

// The display loop: frame f is due at start + f / 60 s; it never waits for the network.
Result<LoopResult> displayLoop(const ClientArgs& a, const std::vector<Camera>& cameras,
                               remote::Client& client, warp::Warper& warper,
                               raster::Renderer* truthRenderer, const scene::Scene* scene) {
    const int frames = a.frames > 0 ? a.frames : int(cameras.size());
    LoopResult r;
    r.frames.reserve(size_t(frames));
    warp::WarpOptions options;
    warp::WarpFrame left, right;
    raster::FrameBuffers truth;
    Progress progress("display", size_t(frames));
    const auto start = std::chrono::steady_clock::now();
    auto due = [&](int frame) {  // when `frame` is shown
        return start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                           std::chrono::duration<double>(frame / kDisplayHz));
    };
    for (int f = 0; f < frames; ++f) {
        std::this_thread::sleep_until(due(f));
        const Camera& cam = cameras[size_t(f % int(cameras.size()))];
        client.setPose(displayPoseMessage(cameras, f, kDisplayHz));
        std::shared_ptr<const remote::ReceivedSet> ref = client.newest();
        const warp::ReferenceSet* sets[] = {&ref->set};
        FrameStat s;
        s.frame = f;
        Stopwatch clock;
        Status warped =
            a.stereo ? warp::warpStereo(warper, sets, cam, kEyeSeparation, options, &left, &right)
                     : warper.warp(sets, cam, options, &left);
        s.warpMs = clock.elapsedMs();
        if (!warped) return warped;
        // A set the server rendered before any pose of ours (timestamp 0) has no age to report.
        s.referenceAgeMs = ref->requestTimestampUs == 0
                               ? -1.0
                               : double(remote::clientNowUs() - ref->requestTimestampUs) * 1e-3;
        s.bytesReceived = client.stats().bytesReceived;
        s.sequence = ref->sequence;
        if (f % a.every == 0) {
            if (truthRenderer) {
                // Mono: the display camera; stereo: the left eye against its own render.
                Camera truthCam = cam;
                if (a.stereo) {
                    CameraDesc d = cam.desc();
                    Vec3 side = glm::normalize(glm::cross(cam.forwardDir(), cam.upDir()));
                    d.eyePos -= side * (kEyeSeparation * 0.5f);
                    d.targetPos -= side * (kEyeSeparation * 0.5f);
                    truthCam = *Camera::create(d);
                }
                truth.resize(truthCam.width(), truthCam.height());
                truthRenderer->render(*scene, truthCam, {}, truth.targets());
                s.psnrDb = std::min(psnr(left.color, truth.color), kIdenticalPsnrDb);
            }
            if (!a.out.empty()) {
                Image<Rgba8> image = a.stereo ? stereo::composeStereo(left.color, right.color,
                                                                      stereo::Layout::kSideBySide)
                                              : left.color;
                PLX_RETURN_IF_ERROR(writePng(
                    (std::filesystem::path(a.out) / fmt::format("frame-{:05d}.png", f)).string(),
                    image));
                ++r.written;
            }
        }
        r.frames.push_back(s);
        progress.step();
    }
    // The last frame is shown for its interval too, as on a display: N frames that keep up take
    // N / 60 s (to the end of the last warp, 1 frame read as 1,300 frames/s, 3 as 90).
    std::this_thread::sleep_until(due(frames));
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

// The median of a field over the frames that have it (>= 0); none where no frame has.
std::optional<double> medianOf(const std::vector<FrameStat>& frames, double FrameStat::*field) {
    std::vector<double> v;
    for (const FrameStat& f : frames)
        if (f.*field >= 0.0) v.push_back(f.*field);
    if (v.empty()) return std::nullopt;
    return median(v);
}

// Peak bytes per display pixel beyond the scene and the reference sets (whose faces the server
// caps, remote::kMaxFaceSize), for checkImageMemory: the warped frames (two with --stereo),
// the local render they are held against (--scene), the frames written (--out). The growth of
// the peak from 1024x1024 to 2048x2048 (office:2, server face size 512): mono 19.6, stereo
// 28.8; with --out 27.9 and 42.3; with --scene 29.3, 35.7, and with both 40.2, 54.4. Rounded
// up; RemoteCli.ClientMemoryEstimateHoldsItsPeak holds them to the measured peak.
double clientBytesPerPixel(const ClientArgs& a) {
    double bytes = a.stereo ? 30.0 : 21.0;
    if (!a.out.empty()) bytes += a.stereo ? 16.0 : 9.0;
    if (!a.scene.empty()) bytes += 12.0;
    return bytes;
}

int runClient(const ClientArgs& a) {
    auto p = plan(a);
    if (!p) return fail(p.status().message(), kExitUsage);
    std::optional<scene::Scene> scene;
    if (!a.scene.empty()) {
        auto loaded = loadSceneChecked(a.scene);
        if (!loaded) return fail(loaded.status());
        scene = std::move(loaded).value();
    }
    auto cameras = pathCameras(a, p->size, scene ? &*scene : nullptr);
    if (!cameras) return fail(cameras.status());
    auto memory = checkImageMemory(
        fmt::format("client{} at {}x{}", a.stereo ? " --stereo" : "", p->size.x, p->size.y),
        clientBytesPerPixel(a) * double(p->size.x) * double(p->size.y),
        scene ? scene->triangleCount() : 0);
    if (!memory) return fail(memory.status());
    if (!a.out.empty())
        if (Status s = createOutputFolder(a.out); !s) return fail(s);
    auto warper = warp::Warper::create(a.threads);
    if (!warper) return fail(warper.status().message(), kExitUsage);
    std::unique_ptr<raster::Renderer> truthRenderer;
    if (scene) truthRenderer = std::move(raster::Renderer::create({a.threads})).value();

    remote::ClientConfig cc;
    cc.host = p->url.host;
    cc.port = p->url.port;
    cc.path = p->url.path;
    cc.token = a.token;
    cc.sourceAddress = a.sourceAddress;
    cc.layout = p->layout;
    cc.faceSize = remoteReferenceFor(cameras->front(), p->layout).faceSize;
    auto client = remote::Client::create(cc);
    if (!client) return fail(client.status().message(), kExitUsage);
    (*client)->setPose(displayPoseMessage(*cameras, 0, kDisplayHz));
    if (!(*client)->waitForFirst(a.waitS * 1000.0)) {
        Status fatal = (*client)->fatal();
        const std::string lastError = (*client)->stats().lastError;
        (*client)->stop();
        if (!fatal.isOk()) return fail(fmt::format("{}: {}", a.url, fatal.message()));
        return fail(fmt::format("no reference set from {} within {:g} s{}", a.url, a.waitS,
                                lastError.empty() ? "" : " (last: " + lastError + ")"));
    }
    auto loop = displayLoop(a, *cameras, **client, **warper, truthRenderer.get(),
                            scene ? &*scene : nullptr);
    remote::ClientStats cs = (*client)->stats();
    (*client)->stop();
    if (!loop) return fail(loop.status());
    if (!a.out.empty())
        if (Status s = writeText((std::filesystem::path(a.out) / "stats.csv").string(),
                                 statsCsv(loop->frames));
            !s)
            return fail(s);

    const int frames = int(loop->frames.size());
    const double fps = loop->seconds > 0.0 ? double(frames) / loop->seconds : 0.0;
    const double bytesPerRef =
        cs.referencesReceived ? double(cs.bytesReceived) / double(cs.referencesReceived) : 0.0;
    std::shared_ptr<const remote::ReceivedSet> last = (*client)->newest();
    double rawBytes = 0.0;
    for (const warp::ReferenceView& v : last->set.views)
        rawBytes += 8.0 * double(v.color.pixelCount());
    nlohmann::json doc = {
        {"url", a.url},
        {"size", fmt::format("{}x{}", p->size.x, p->size.y)},
        {"stereo", a.stereo},
        {"frames", frames},
        {"seconds", loop->seconds},
        {"client_fps", fps},
        {"warp_ms_median", valueOrNull(medianOf(loop->frames, &FrameStat::warpMs))},
        {"reference_age_ms_median",
         valueOrNull(medianOf(loop->frames, &FrameStat::referenceAgeMs))},
        {"references_received", cs.referencesReceived},
        {"references_per_s", double(cs.referencesReceived) / loop->seconds},
        {"references_dropped", cs.referencesDropped},
        {"bytes_per_reference", bytesPerRef},
        {"raw_bytes_per_reference", rawBytes},
        {"face_size", cs.faceSize},
        {"rtt_ms", valueOrNull(cs.rttMs >= 0.0, cs.rttMs)},
        {"decode_ms_mean", cs.decodeMsMean},
        {"reconnects", std::max<int64_t>(0, cs.connects - 1)},
        {"frames_written", loop->written}};
    if (scene) doc["psnr_db_median"] = valueOrNull(medianOf(loop->frames, &FrameStat::psnrDb));
    if (!cs.lastError.empty()) doc["last_error"] = cs.lastError;  // of a failed reconnection
    doc.update(memoryJson(*memory));
    if (a.json) {
        printJson(doc);
    } else {
        // A figure JSON gives as null (none measured) reads "unknown".
        auto figure = [](const nlohmann::json& v, const char* format) {
            return v.is_null() ? std::string("unknown")
                               : fmt::format(fmt::runtime(format), v.get<double>());
        };
        fmt::print(
            "{} in {:.2f} s ({:.1f} frames/s) at {}; warp {}, reference age {} "
            "(medians)\n",
            counted(uint64_t(frames), "frame"), loop->seconds, fps, doc["size"].get<std::string>(),
            figure(doc["warp_ms_median"], "{:.2f} ms"),
            figure(doc["reference_age_ms_median"], "{:.0f} ms"));
        fmt::print("{} ({:.1f}/s), {:.1f} KiB each (1/{:.0f} of raw), RTT {}\n",
                   counted(uint64_t(cs.referencesReceived), "reference set"),
                   doc["references_per_s"].get<double>(), bytesPerRef / 1024.0,
                   bytesPerRef > 0.0 ? rawBytes / bytesPerRef : 0.0,
                   figure(doc["rtt_ms"], "{:.0f} ms"));
        if (scene)
            fmt::print("PSNR {} against the local render (median)\n",
                       figure(doc["psnr_db_median"], "{:.1f} dB"));
        if (!a.out.empty())
            fmt::print("wrote {} and stats.csv to {}\n", counted(uint64_t(loop->written), "frame"),
                       a.out);
    }
    return kExitOk;
}

}  // namespace

Command registerClient(CLI::App& app) {
    auto a = std::make_shared<ClientArgs>();
    CLI::App* sub = app.add_subcommand(
        "client", "Play a pose path against a render server, warping its reference sets");
    sub->footer(
        "Example: parallax client ws://127.0.0.1:8080 --walk 300 --scene office:8 --json\n"
        "         parallax client ws://127.0.0.1:8080 --path poses.json --out out/client --every "
        "10\n"
        "Plays the path at 60 Hz in real time (looping it when --frames asks for more), warping "
        "the newest reference set each frame; it never waits for the network and reconnects "
        "when the server goes away. --scene renders the truth locally (every --every frames) "
        "for psnr_db_median; --walk needs it for the walk's start. --out writes "
        "frame-NNNNN.png every --every frames and stats.csv (per frame: warp ms, reference "
        "age ms, bytes received).");
    sub->add_option("url", a->url, "Server address, ws://HOST:PORT (IPv6: ws://[::1]:PORT)")
        ->required();
    sub->add_option("--token", a->token, "Token the server asks for");
    sub->add_option("--source-address", a->sourceAddress,
                    "Local IP address to connect from (default: the system's choice)");
    sub->add_option("--path", a->path, "Pose path: a JSON list of poses (as parallax stereo)");
    sub->add_option("--walk", a->walk, "Pose path: N poses of the built-in walk (needs --scene)");
    sub->add_option("--size", a->size, "Display size WxH")->capture_default_str();
    sub->add_option("--refs", a->refs, "Requested layout (the server's wins)")
        ->capture_default_str();
    sub->add_flag("--stereo", a->stereo, "Warp both eyes (65 mm apart); frames side by side");
    sub->add_option("--frames", a->frames, "Display frames (default: the path's poses)");
    sub->add_option("--out", a->out, "Folder for frames and stats.csv")
        ->check(outputPath(OutputKind::kFolder));
    sub->add_option("--every", a->every, "Write (and compare) every Nth frame")
        ->capture_default_str();
    sub->add_option("--scene", a->scene, "The scene, for the walk and the local ground truth");
    sub->add_option("--threads", a->threads, "Warp threads (0: all cores)");
    sub->add_option("--wait", a->waitS, "Seconds to wait for the first reference set")
        ->capture_default_str();
    sub->add_flag("--json", a->json, "Print a JSON summary on stdout");
    return {sub, [a] { return runClient(*a); }};
}

}  // namespace plx::cli
