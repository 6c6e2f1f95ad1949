// parallax stream walk DIR|URL: a walkthrough of a streaming database on the simulated link or
// over HTTP (Marvie & Bouatouch section 7): per frame the resident texture bytes against the
// budget, the bytes downloaded, the progressive downloading quality and the client's frame time.

#include <chrono>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include <plx/raster/raster.h>
#include <plx/stereo/path.h>
#include <plx/stream/client.h>
#include <plx/stream/link_simulator.h>
#include <plx/stream/tour.h>

#include "commands.h"
#include "view.h"

namespace plx::cli {
namespace {

struct WalkArgs {
    std::string location;
    double bandwidthKbit = 0.0;  // 0: unlimited
    double latencyMs = 0.0;
    double budgetMb = 4.0, staticBudgetMb = 16.0, dtMaxS = 0.5, dtMaxStaticS = 20.0;
    double tStaticS = 1.0;
    std::string path;
    std::optional<int> walk;
    bool tour = false;
    std::string policy = "ach";
    double stopS = stream::TourConfig{}.stopS;
    std::string size = "640x480";
    double fps = 30.0;
    std::string out;
    bool json = false;
};

constexpr double kMaxMb = 1 << 20;   // 1 TiB: beyond any graphics memory
constexpr double kMaxSeconds = 1e6;  // link and timing parameters

Status checkRange(const char* name, double v, double lo, double hi) {
    if (std::isfinite(v) && v >= lo && v <= hi) return Status::ok();
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("{} {} outside {} .. {}", name, v, lo, hi));
}

Status checkArgs(const WalkArgs& a) {
    PLX_RETURN_IF_ERROR(checkRange("--bandwidth", a.bandwidthKbit, 0.0, 1e9));
    PLX_RETURN_IF_ERROR(checkRange("--latency", a.latencyMs, 0.0, kMaxSeconds * 1e3));
    PLX_RETURN_IF_ERROR(checkRange("--budget", a.budgetMb, 0.0, kMaxMb));
    PLX_RETURN_IF_ERROR(checkRange("--static-budget", a.staticBudgetMb, 0.0, kMaxMb));
    PLX_RETURN_IF_ERROR(checkRange("--dt-max", a.dtMaxS, 0.0, kMaxSeconds));
    PLX_RETURN_IF_ERROR(checkRange("--dt-max-static", a.dtMaxStaticS, 0.0, kMaxSeconds));
    PLX_RETURN_IF_ERROR(checkRange("--t-static", a.tStaticS, 0.0, kMaxSeconds));
    PLX_RETURN_IF_ERROR(checkRange("--fps", a.fps, 1.0, 1000.0));
    PLX_RETURN_IF_ERROR(checkWalk(a.walk));
    PLX_RETURN_IF_ERROR(checkRange("--stop", a.stopS, 0.0, 3600.0));
    const int walks = int(a.walk.has_value()) + int(!a.path.empty()) + int(a.tour);
    if (walks > 1)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "--walk, --path and --tour exclude each other");
    if (walks == 0)
        return errorStatus(ErrorCode::kInvalidArgument, "give --path P.json, --walk N or --tour");
    PLX_RETURN_IF_ERROR(stream::parsePolicy(a.policy).status());
    return parseSize(a.size).status();
}

// One whole file through the transport, before the walk (the root for the built-in walk's
// first viewpoint, the cells for the tour). Waits at most 30 s of wall time for a real one.
Result<std::vector<uint8_t>> fetchFile(stream::Fetcher& fetcher, const std::string& path,
                                       uint64_t maxBytes) {
    fetcher.submit({0, path, std::nullopt, maxBytes}, 0.0);
    auto start = std::chrono::steady_clock::now();
    for (;;) {
        double waited =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        for (stream::FetchCompletion& c : fetcher.poll(1e9)) {
            if (!c.status) return c.status;
            return std::move(c.bytes);
        }
        if (waited > 30.0)
            return errorStatus(ErrorCode::kIoError, fmt::format("{}: no answer in 30 s", path));
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
}

Result<stream::RootFile> fetchRoot(stream::Fetcher& fetcher) {
    auto bytes = fetchFile(fetcher, "root.json", stream::kMaxRootBytes);
    if (!bytes) return bytes.status();
    return stream::parseRoot(*bytes);
}

// The tour through every cell (section 7.1) from the cells' hulls, each cell file fetched once.
Result<std::vector<stereo::Pose>> tourPoses(stream::Fetcher& fetcher, const stream::RootFile& root,
                                            double stopS, double fps) {
    std::vector<Aabb> boxes;
    for (uint32_t c = 0; c < root.cells; ++c) {
        const std::string url = stream::cellUrl(c);
        auto bytes = fetchFile(fetcher, url, stream::kMaxCellFileBytes);
        if (!bytes) return bytes.status();
        auto cell = stream::parseCell(*bytes);
        if (!cell)
            return errorStatus(cell.status().code(),
                               fmt::format("{}: {}", url, cell.status().message()));
        boxes.push_back({cell->hullMin, cell->hullMax});
    }
    stream::TourConfig config;
    config.stopS = stopS;
    config.fps = fps;
    auto tour = stream::roomTour(boxes, config);
    if (!tour) return tour.status();
    std::vector<stereo::Pose> poses;
    for (const stream::TourPose& t : *tour) poses.push_back({t.eyePos, t.targetPos});
    return poses;
}

Result<std::vector<Camera>> walkCameras(const WalkArgs& a, const stream::RootFile& root,
                                        stream::Fetcher& fetcher) {
    std::vector<stereo::Pose> poses;
    if (a.tour) {
        auto tour = tourPoses(fetcher, root, a.stopS, a.fps);
        if (!tour) return tour.status();
        poses = std::move(tour).value();
    } else if (a.walk) {
        scene::Scene s;  // the built-in walk needs only the start viewpoint
        const stream::RootViewpoint& v = root.viewpoints.front();
        s.viewpoints.push_back({v.name, v.eyePos, v.targetPos, v.upDir, v.fovYDegrees});
        poses = stereo::builtinWalk(s, *a.walk);
    } else {
        auto loaded = stereo::loadPath(a.path);
        if (!loaded) return loaded.status();
        poses = std::move(loaded).value();
    }
    IVec2 size = parseSize(a.size).value();
    float diagonal = glm::length(root.boundsMax - root.boundsMin);
    std::vector<Camera> cameras;
    for (size_t i = 0; i < poses.size(); ++i) {
        CameraDesc d;
        d.eyePos = poses[i].eyePos, d.targetPos = poses[i].targetPos, d.upDir = poses[i].upDir;
        d.fovYDegrees = poses[i].fovYDegrees;
        d.farPlane = std::max(10.0f, 2.0f * diagonal);
        d.width = size.x, d.height = size.y;
        auto cam = Camera::create(d);
        if (!cam)
            return errorStatus(cam.status().code(),
                               fmt::format("pose {}: {}", i, cam.status().message()));
        cameras.push_back(*cam);
    }
    return cameras;
}

// The paper's screenshot moments (Fig. 3: 10 s, 35 s and 80 s after the downloads start).
constexpr double kShotTimesS[] = {10.0, 35.0, 80.0};

// Peak bytes per frame pixel beyond the database's scene and textures, for checkImageMemory:
// the frame's targets, and the PNG of a screenshot when the walk reaches one with --out. The
// growth of the peak from 1024x1024 to 2048x2048 (museum:4): 12.1, with a screenshot 17.1.
// Rounded up; MemoryCli.EstimatesHoldTheMeasuredPeak holds them to the measured peak. What the
// walk downloads (geometry, texture levels) comes on top, bounded by the budgets, not the size.
double walkBytesPerPixel(const WalkArgs& a, size_t frames) {
    const bool screenshot = !a.out.empty() && double(frames) / a.fps >= kShotTimesS[0];
    return screenshot ? 19.0 : 14.0;
}

int runWalk(const WalkArgs& a) {
    if (Status s = checkArgs(a); !s) return fail(s.message(), kExitUsage);
    stream::LinkOptions link{a.bandwidthKbit * 1e3, a.latencyMs * 1e-3};
    auto fetcher = stream::openFetcher(a.location, link);
    if (!fetcher) return fail(fetcher.status());
    // The root through a transport of its own, so that the walk's link starts idle.
    auto probe = stream::openFetcher(a.location, {});
    if (!probe) return fail(probe.status());
    auto root = fetchRoot(**probe);
    if (!root) return fail(root.status());
    auto cameras = walkCameras(a, *root, **probe);
    if (!cameras) return fail(cameras.status());
    const Camera& view = cameras->front();
    auto memory = checkImageMemory(
        fmt::format("stream walk at {}x{}", view.width(), view.height()),
        walkBytesPerPixel(a, cameras->size()) * double(view.width()) * double(view.height()));
    if (!memory) return fail(memory.status());

    stream::ClientConfig config;
    config.budgetBytes = mebibytes(a.budgetMb);
    config.staticBudgetBytes = mebibytes(a.staticBudgetMb);
    config.dtMaxS = a.dtMaxS, config.dtMaxStaticS = a.dtMaxStaticS, config.tStaticS = a.tStaticS;
    config.policy = stream::parsePolicy(a.policy).value();
    stream::StreamClient client(fetcher->get(), config);

    auto renderer = raster::Renderer::create();
    if (!renderer) return fail(renderer.status());
    raster::FrameBuffers buffers;
    buffers.resize(view.width(), view.height());
    raster::RenderOptions options;
    options.shading = raster::Shading::kTextured;
    if (!a.out.empty())
        if (Status s = ensureParentDirectory(a.out + "/"); !s) return fail(s);
    size_t nextShot = 0;

    nlohmann::json frames = nlohmann::json::array();
    std::string csv =
        "frame,time_s,budget_bytes,resident_bytes,downloaded_bytes,quality,frame_ms\n";
    uint64_t maxResident = 0;
    stream::FrameReport last;
    Progress progress("walk", cameras->size());
    // A real transport (HTTP) downloads in wall-clock time: frames are then paced at --fps.
    const bool paced = (*fetcher)->realTime();
    const auto walkStart = std::chrono::steady_clock::now();
    for (size_t i = 0; i < cameras->size(); ++i) {
        if (paced)
            std::this_thread::sleep_until(
                walkStart + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                std::chrono::duration<double>(double(i) / a.fps)));
        Stopwatch clock;
        last = client.frame((*cameras)[i], double(i) / a.fps);
        // The display step: the downloaded geometry with the resident levels only.
        auto drawn = client.residentScene();
        if (drawn) (*renderer)->render(*drawn, (*cameras)[i], options, buffers.targets());
        double ms = clock.elapsedMs();
        if (!a.out.empty() && nextShot < std::size(kShotTimesS) &&
            last.timeS >= kShotTimesS[nextShot]) {
            std::string png =
                fmt::format("{}/frame-{:03}s.png", a.out, int(kShotTimesS[nextShot++]));
            if (Status s = writePng(png, buffers.color); !s) return fail(s);
        }
        maxResident = std::max(maxResident, last.residentBytes);
        frames.push_back({{"time_s", last.timeS},
                          {"budget_bytes", last.budgetBytes},
                          {"resident_bytes", last.residentBytes},
                          {"downloaded_bytes", last.downloadedBytes},
                          {"quality", last.quality},
                          {"static", last.isStatic},
                          {"cell", valueOrNull(last.currentCell >= 0, last.currentCell)},
                          {"frame_ms", ms}});
        csv += fmt::format("{},{:.4f},{},{},{},{:.4f},{:.3f}\n", i, last.timeS, last.budgetBytes,
                           last.residentBytes, last.downloadedBytes, last.quality, ms);
        progress.step();
    }
    for (const std::string& line : client.log())
        if (Status s = warn(line); !s) return fail(s);  // --strict
    if (!a.out.empty())
        if (Status s = writeText(a.out + "/frames.csv", csv); !s) return fail(s);
    if (a.json) {
        nlohmann::json doc = {{"frames", cameras->size()},
                              {"budget_bytes", config.budgetBytes},
                              {"static_budget_bytes", config.staticBudgetBytes},
                              {"max_resident_bytes", maxResident},
                              {"downloaded_bytes", last.downloadedBytes},
                              {"quality_final", last.quality},
                              {"failed_requests", client.failedRequests()},
                              {"bandwidth_kbit", a.bandwidthKbit},
                              {"policy", a.policy},
                              {"per_frame", frames}};
        doc.update(memoryJson(*memory));
        printJson(doc);
    } else {
        fmt::print(
            "{}: max resident {} bytes (budget {}, static {}), downloaded {} bytes, "
            "quality {:.1f}%, {}\n",
            counted(cameras->size(), "frame"), maxResident, config.budgetBytes,
            config.staticBudgetBytes, last.downloadedBytes, 100.0 * last.quality,
            counted(client.failedRequests(), "failed request"));
    }
    return kExitOk;
}

}  // namespace

Command registerStreamWalk(CLI::App* stream, Command inner) {
    auto a = std::make_shared<WalkArgs>();
    CLI::App* walk = stream->add_subcommand(
        "walk",
        "Walk through a streaming database, simulated link or HTTP (Marvie & Bouatouch 6, 7)");
    walk->footer(
        "Example: parallax stream walk out/museum64 --bandwidth 56 --walk 600 --json\n"
        "         parallax stream walk out/m16 --tour --stop 10 --bandwidth 56 --latency 50\n"
        "DIR is a database folder (a simulated link: --bandwidth, --latency) or "
        "http://HOST:PORT/PATH (any web server with Range requests; frames paced in real time). "
        "--tour walks through every cell (centres in rows, at eye height, --stop s still in each). "
        "Frames advance a simulated clock at --fps. The budgets are M^mem (moving) and "
        "M^mem_static (after --t-static s unmoved); --dt-max caps a level's estimated download "
        "time. Frames draw the downloaded geometry with the resident levels only (grey where none "
        "is resident yet). --out DIR writes DIR/frames.csv and the frames at 10, 35 and 80 s.\n"
        "JSON: frames, budget_bytes, max_resident_bytes, downloaded_bytes, quality_final, "
        "failed_requests, per_frame, memory_estimate_mb and peak_memory_mb (the process).");
    walk->add_option("location", a->location, "Database folder or http://HOST:PORT/PATH")
        ->required();
    walk->add_option("--bandwidth", a->bandwidthKbit, "Link bandwidth, kbit/s (0: unlimited)");
    walk->add_option("--latency", a->latencyMs, "Latency per request, ms");
    walk->add_option("--budget", a->budgetMb, "Texture memory budget M^mem, MB")
        ->capture_default_str();
    walk->add_option("--static-budget", a->staticBudgetMb, "Budget with a static viewpoint, MB")
        ->capture_default_str();
    walk->add_option("--dt-max", a->dtMaxS, "Longest estimated download of a level, s")
        ->capture_default_str();
    walk->add_option("--dt-max-static", a->dtMaxStaticS, "dt_max with a static viewpoint, s")
        ->capture_default_str();
    walk->add_option("--t-static", a->tStaticS, "Seconds unmoved before the static parameters")
        ->capture_default_str();
    walk->add_option(
            "--policy", a->policy,
            "Budget allocation: ach (the paper), ach-return (ACH, unusable shares go on), "
            "ach-texture (ACH per texture), lru or equal (baselines)")
        ->capture_default_str();
    walk->add_option("--path", a->path, "Walkthrough: a JSON list of poses");
    walk->add_option("--walk", a->walk, "Walkthrough: N poses of the built-in walk");
    walk->add_flag("--tour", a->tour,
                   "Walkthrough: every cell in serpentine order at 1.2 m/s (section 7.1)");
    walk->add_option("--stop", a->stopS, "Seconds standing still in each cell of --tour")
        ->capture_default_str();
    walk->add_option("--size", a->size, "Frame size WxH")->capture_default_str();
    walk->add_option("--fps", a->fps, "Frames per simulated second")->capture_default_str();
    walk->add_option("--out", a->out, "Folder for frames.csv")
        ->check(outputPath(OutputKind::kFolder));
    walk->add_flag("--json", a->json, "Print a JSON summary on stdout");
    return {inner.app, [a, walk, run = inner.run] { return walk->parsed() ? runWalk(*a) : run(); }};
}

}  // namespace plx::cli
