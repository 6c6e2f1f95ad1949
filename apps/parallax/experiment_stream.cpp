// Marvie & Bouatouch section 7 on the link simulator: the tour at several bandwidths, frame time
// against a full-resolution baseline, and the allocation policies compared by texture PSNR.

#include "experiment_stream.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>

#include <plx/core/file.h>
#include <plx/core/metrics.h>
#include <plx/core/timing.h>
#include <plx/ptm/decoder.h>
#include <plx/raster/raster.h>
#include <plx/scene/generators.h>
#include <plx/stream/cells.h>
#include <plx/stream/client.h>
#include <plx/stream/database.h>
#include <plx/stream/link_simulator.h>

#include "cli.h"
#include "report.h"

namespace plx::cli {
namespace {

// Plot points: one per this many frames (the CSV keeps every frame).
constexpr size_t kPlotStride = 15;

using FullTextures = std::map<std::string, scene::Texture>;

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

double percentile(std::vector<double> v, double p) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, size_t(p * double(v.size())))];
}

Result<std::vector<Camera>> tourCameras(const scene::Scene& scene, const stream::Cells& cells,
                                        const StreamExperimentConfig& c) {
    auto tour = stream::roomTour(cells.boxes, c.tour);
    if (!tour) return tour.status();
    const Aabb bounds = scene.bounds();
    std::vector<Camera> cameras;
    cameras.reserve(tour->size());
    for (const stream::TourPose& p : *tour) {
        CameraDesc d;
        d.eyePos = p.eyePos, d.targetPos = p.targetPos;
        d.width = c.width, d.height = c.height;
        d.farPlane = std::max(10.0f, 2.0f * glm::length(bounds.hi - bounds.lo));
        auto cam = Camera::create(d);
        if (!cam) return cam.status();
        cameras.push_back(*cam);
    }
    return cameras;
}

// Every PTM file of the database decoded at full resolution with its mip chain: the baseline's
// textures and the reference of the PSNR comparison. Also the client's measure of their bytes
// (texel bytes of every stored level).
struct DecodedTextures {
    FullTextures textures;
    std::map<std::string, uint64_t> chainBytes;
    double loadMs = 0.0;
};

Result<DecodedTextures> decodeTextures(const std::string& db, size_t count) {
    DecodedTextures out;
    Stopwatch clock;
    for (size_t t = 0; t < count; ++t) {
        const std::string url = stream::textureUrl(uint32_t(t));
        auto file = readFileChecked(db + "/" + url);
        if (!file) return file.status();
        std::span<const uint8_t> bytes(reinterpret_cast<const uint8_t*>(file->data()),
                                       file->size());
        auto header = ptm::parseHeader(bytes);
        if (!header) return header.status();
        uint64_t chain = 0;
        for (int k = 0; k < header->levelCount; ++k) {
            ptm::LevelSize s = header->levelSize(k);
            chain += uint64_t(s.width) * uint64_t(s.height) * uint64_t(header->components);
        }
        auto image = ptm::decodeImage(bytes);
        if (!image) return image.status();
        scene::Texture texture;
        texture.mips.push_back(toRgba8(*image));
        scene::buildMipChain(&texture);
        out.textures.emplace(url, std::move(texture));
        out.chainBytes.emplace(url, chain);
    }
    out.loadMs = clock.elapsedMs();
    return out;
}

// The largest full-resolution texel bytes of one cell's PVS: what the budget is measured against.
Result<uint64_t> largestPvsBytes(const std::string& db, size_t cells,
                                 const std::map<std::string, uint64_t>& chainBytes) {
    std::vector<std::vector<std::string>> texturesOf(cells);
    std::vector<stream::CellFile> files;
    for (uint32_t c = 0; c < cells; ++c) {
        auto text = readFileChecked(db + "/" + stream::cellUrl(c));
        if (!text) return text.status();
        auto cell = stream::parseCell(
            std::span(reinterpret_cast<const uint8_t*>(text->data()), text->size()));
        if (!cell) return cell.status();
        for (const stream::UrlBytes& t : cell->textures) texturesOf[c].push_back(t.url);
        files.push_back(std::move(cell).value());
    }
    uint64_t most = 0;
    for (const stream::CellFile& f : files) {
        std::set<std::string> urls;
        for (const stream::PvsUrlEntry& e : f.pvs)
            if (auto idx = stream::cellIndexOfUrl(e.url, uint32_t(cells)))
                urls.insert(texturesOf[*idx].begin(), texturesOf[*idx].end());
        uint64_t sum = 0;
        for (const std::string& u : urls)
            if (auto it = chainBytes.find(u); it != chainBytes.end()) sum += it->second;
        most = std::max(most, sum);
    }
    return most;
}

struct FrameRenderer {
    std::unique_ptr<raster::Renderer> renderer;
    raster::FrameBuffers buffers;
    raster::RenderOptions options;

    Image<Rgba8> draw(const scene::Scene& scene, const Camera& camera) {
        renderer->render(scene, camera, options, buffers.targets());
        return buffers.color;
    }
};

// What one walk of the tour measures besides its frame reports.
struct WalkPlan {
    double kbit = 0.0;
    stream::ClientConfig client;
    const std::vector<double>* shotTimesS = nullptr;  // render and keep these frames
    const scene::Scene* baseline = nullptr;           // render it each frame, timed
    BaselineRun* baselineRun = nullptr;
    bool timeFrames = false;  // render each streamed frame, timed
    int compareEvery = 0;     // PSNR against fullTextures
    const FullTextures* fullTextures = nullptr;
};

struct WalkOutcome {
    BandwidthRun run;
    std::vector<double> psnrDb, mse;
    std::vector<size_t> comparedFrames;  // the frame index of each psnrDb entry
    double residentSum = 0.0;
};

WalkOutcome walk(const std::string& db, double latencyS, const std::vector<Camera>& cameras,
                 const WalkPlan& plan, FrameRenderer& r, double fps) {
    WalkOutcome out;
    BandwidthRun& run = out.run;
    run.kbit = plan.kbit;
    run.maxBudgetBytes = std::max(plan.client.budgetBytes, plan.client.staticBudgetBytes);
    stream::LinkSimulator link(db, {plan.kbit * 1e3, latencyS});
    stream::StreamClient client(&link, plan.client);
    size_t nextShot = 0;
    for (size_t i = 0; i < cameras.size(); ++i) {
        const double nowS = double(i) / fps;
        const bool shot = plan.shotTimesS && nextShot < plan.shotTimesS->size() &&
                          nowS >= (*plan.shotTimesS)[nextShot];
        const bool compare = plan.compareEvery > 0 && i % size_t(plan.compareEvery) == 0;
        Stopwatch clock;
        stream::FrameReport report = client.frame(cameras[i], nowS);
        // The display step: the downloaded geometry with the resident levels only.
        if (plan.timeFrames || shot || compare) {
            auto drawn = client.residentScene();
            Image<Rgba8> image;
            if (drawn) image = r.draw(*drawn, cameras[i]);
            if (plan.timeFrames) run.frameMs.push_back(clock.elapsedMs());
            if (shot) {
                if (!drawn) image = Image<Rgba8>(r.buffers.color.width(), r.buffers.color.height());
                run.shots.emplace_back((*plan.shotTimesS)[nextShot++], image);
            }
            if (compare && drawn) {
                auto full = client.residentScene(plan.fullTextures);
                const double dB = psnr(image, r.draw(*full, cameras[i]));
                out.psnrDb.push_back(std::isfinite(dB) ? dB : kIdenticalPsnrDb);
                out.comparedFrames.push_back(i);
                out.mse.push_back(std::isfinite(dB) ? 255.0 * 255.0 / std::pow(10.0, dB / 10.0)
                                                    : 0.0);
            }
        }
        if (plan.baseline) {
            Stopwatch baselineClock;
            (void)r.draw(*plan.baseline, cameras[i]);
            plan.baselineRun->frameMs.push_back(baselineClock.elapsedMs());
        }
        if (run.firstAt90S < 0.0 && report.quality >= 0.9) run.firstAt90S = nowS;
        run.maxResidentBytes = std::max(run.maxResidentBytes, report.residentBytes);
        run.framesOverBudget += report.residentBytes > report.budgetBytes;
        out.residentSum += double(report.residentBytes);
        run.frames.push_back(report);
    }
    if (!run.frames.empty()) {
        run.qualityFinal = run.frames.back().quality;
        run.downloadedBytes = run.frames.back().downloadedBytes;
    }
    run.failedRequests = client.failedRequests();
    return out;
}

// The PSNR of the mean squared error of the compared frames from index `firstFrame` on.
double psnrFromFrame(const WalkOutcome& w, size_t firstFrame) {
    double sum = 0.0;
    size_t n = 0;
    for (size_t k = 0; k < w.mse.size(); ++k)
        if (w.comparedFrames[k] >= firstFrame) sum += w.mse[k], ++n;
    const double meanMse = n ? sum / double(n) : 0.0;
    return meanMse > 0.0 ? 10.0 * std::log10(255.0 * 255.0 / meanMse) : kIdenticalPsnrDb;
}

PolicyRow policyRow(stream::AllocationPolicy policy, uint64_t budget, const WalkOutcome& w,
                    const stream::TourConfig& tour) {
    PolicyRow row;
    row.policy = policy;
    row.budgetBytes = budget;
    row.framesCompared = int(w.mse.size());
    row.psnrDb = psnrFromFrame(w, 0);
    row.psnrAfterFirstStopDb = psnrFromFrame(w, size_t(std::ceil(tour.stopS * tour.fps)));
    row.psnrDbMedian = median(w.psnrDb);
    for (size_t k = 0; k < w.psnrDb.size(); ++k)
        row.framePsnrDb.emplace_back(w.comparedFrames[k], w.psnrDb[k]);
    row.meanResidentBytes = w.residentSum / double(std::max<size_t>(1, w.run.frames.size()));
    row.maxResidentBytes = w.run.maxResidentBytes;
    row.framesOverBudget = w.run.framesOverBudget;
    row.downloadedBytes = w.run.downloadedBytes;
    row.qualityFinal = w.run.qualityFinal;
    return row;
}

}  // namespace

std::string bandwidthName(double kbit) {
    if (kbit <= 0.0) return "unlimited";
    if (kbit >= 1000.0) return fmt::format("{:g} Mbit/s", kbit / 1000.0);
    return fmt::format("{:g} kbit/s", kbit);
}

Status checkStreamExperimentConfig(const StreamExperimentConfig& c) {
    auto bad = [](std::string message) {
        return errorStatus(ErrorCode::kInvalidArgument, std::move(message));
    };
    if (c.bandwidthsKbit.empty()) return bad("no bandwidths");
    for (double k : c.bandwidthsKbit)
        if (!(k >= 0.0 && k <= 1e7)) return bad(fmt::format("bandwidth {} outside 0 .. 1e7", k));
    if (!(c.policyKbit >= 0.0 && c.policyKbit <= 1e7))
        return bad(fmt::format("policy bandwidth {} outside 0 .. 1e7", c.policyKbit));
    if (!(c.latencyS >= 0.0 && c.latencyS <= 10.0))
        return bad(fmt::format("latency {} s outside 0 .. 10", c.latencyS));
    if (c.budgetBytes == 0 || c.staticBudgetBytes == 0) return bad("a zero budget");
    for (uint64_t b : c.policyBudgets)
        if (b == 0) return bad("a zero policy budget");
    if (c.dbDir.empty()) return bad("no database folder");
    if (c.psnrEvery < 1) return bad(fmt::format("psnr interval {} below 1", c.psnrEvery));
    if (c.width < 16 || c.height < 16 || c.width > 4096 || c.height > 4096)
        return bad(fmt::format("size {}x{} outside 16 .. 4096", c.width, c.height));
    return Status::ok();
}

// What the experiment adds to the generated scene and its tour (checkImageMemory): per texel
// byte of the scene, the database's PTM files and the baseline's decoded chains beside the
// scene's own textures; per tour frame, the report each walk keeps (the policy walks' one at a
// time) and the frame times, in vectors that grow by doubling; per frame pixel, the frame
// targets, the full-resolution frames the policies are compared with and the screenshots. The
// peak grew by 28 bytes a pixel from 96x72 to 1024x768 (museum:4), and by 2.8 bytes a scene
// texel byte from museum:4 to museum:64 (11 to 89 MB of textures), the scene's own byte held at
// the check; rounded up, the estimate was 1.12-1.21 times the peak from museum:4 to museum:256
// (141k tour frames). MemoryCli.EstimatesHoldTheMeasuredPeak holds it to the peak.
constexpr double kStreamBytesPerTextureByte = 2.0, kStreamBytesPerPixel = 32.0,
                 kStreamFixedBytes = 16e6;
double streamExperimentBytes(const StreamExperimentConfig& c, size_t textureBytes,
                             size_t tourFrames) {
    const double walks = double(c.bandwidthsKbit.size() + 1);
    const double perFrame =
        2.0 * (walks * double(sizeof(stream::FrameReport)) + 2.0 * double(sizeof(double)));
    return kStreamFixedBytes + kStreamBytesPerTextureByte * double(textureBytes) +
           perFrame * double(tourFrames) +
           kStreamBytesPerPixel * double(c.width) * double(c.height);
}

Result<StreamExperiment> runStreamExperiment(const StreamExperimentConfig& config,
                                             const std::function<void(size_t, size_t)>& progress) {
    PLX_RETURN_IF_ERROR(checkStreamExperimentConfig(config));
    StreamExperiment e;
    e.config = config;
    const size_t steps =
        2 + config.bandwidthsKbit.size() + config.policies.size() * config.policyBudgets.size();
    size_t done = 0;
    auto step = [&] {
        if (progress) progress(++done, steps);
    };

    // The database (sections 3 and 5) and the full-resolution textures.
    auto scene = scene::generateFromSpec(config.scene);
    if (!scene) return scene.status();
    auto cells = stream::makeCells(*scene);
    if (!cells) return cells.status();
    auto cameras = tourCameras(*scene, *cells, config);
    if (!cameras) return cameras.status();
    e.tourFrames = cameras->size();
    auto memory = checkImageMemory(
        fmt::format("stream experiment on {} at {}x{}", config.scene, config.width, config.height),
        streamExperimentBytes(config, scene->stats().textureBytes, e.tourFrames),
        scene->triangleCount());
    if (!memory) return memory.status();
    e.memoryEstimateBytes = *memory;
    stream::VisibilityConfig sampling = config.sampling;
    sampling.threads = config.threads;
    auto visibility =
        stream::computeVisibility(*scene, *cells, sampling, 0, uint32_t(cells->boxes.size() - 1));
    if (!visibility) return visibility.status();
    auto built =
        stream::writeDatabase(*scene, *cells, *visibility, sampling, config.scene, config.dbDir);
    if (!built) return built.status();
    e.cells = built->cells, e.textures = built->textures, e.databaseBytes = built->bytes;
    auto decoded = decodeTextures(config.dbDir, built->textures);
    if (!decoded) return decoded.status();
    e.baseline.loadMs = decoded->loadMs;
    for (const auto& [url, bytes] : decoded->chainBytes) e.baseline.textureBytes += bytes;
    auto pvsBytes = largestPvsBytes(config.dbDir, built->cells, decoded->chainBytes);
    if (!pvsBytes) return pvsBytes.status();
    e.pvsTextureBytesMax = *pvsBytes;
    step();

    auto renderer = raster::Renderer::create({config.threads});
    if (!renderer) return renderer.status();
    FrameRenderer r{std::move(renderer).value(), {}, {}};
    r.buffers.resize(config.width, config.height);
    r.options.shading = raster::Shading::kTextured;

    // Fig. 2: the tour at each bandwidth; the slowest gives Fig. 3's frames, the unlimited one
    // is timed against the baseline.
    const double slowest = *std::min_element(
        config.bandwidthsKbit.begin(), config.bandwidthsKbit.end(),
        [](double a, double b) { return (a <= 0 ? 1e300 : a) < (b <= 0 ? 1e300 : b); });
    bool timed = false;
    for (double kbit : config.bandwidthsKbit) {
        WalkPlan plan;
        plan.kbit = kbit;
        plan.client.budgetBytes = config.budgetBytes;
        plan.client.staticBudgetBytes = config.staticBudgetBytes;
        if (kbit == slowest) plan.shotTimesS = &config.shotTimesS;
        if (config.frameTimes && kbit <= 0.0 && !timed) {
            plan.timeFrames = true;
            plan.baseline = &*scene;
            plan.baselineRun = &e.baseline;
            timed = true;
        }
        e.runs.push_back(
            walk(config.dbDir, config.latencyS, *cameras, plan, r, config.tour.fps).run);
        step();
    }
    // Fig. 3's last picture: the full-resolution view at the slowest walk's last shot.
    if (!config.shotTimesS.empty()) {
        size_t frame =
            std::min(cameras->size() - 1, size_t(config.shotTimesS.back() * config.tour.fps));
        e.fullShot = r.draw(*scene, (*cameras)[frame]);
    }
    step();

    // Beyond the paper: the policies at equal budgets, judged by the texture PSNR of the frames.
    for (uint64_t budget : config.policyBudgets) {
        for (stream::AllocationPolicy policy : config.policies) {
            WalkPlan plan;
            plan.kbit = config.policyKbit;
            plan.client.budgetBytes = plan.client.staticBudgetBytes = budget;
            plan.client.policy = policy;
            plan.compareEvery = config.psnrEvery;
            plan.fullTextures = &decoded->textures;
            WalkOutcome w = walk(config.dbDir, config.latencyS, *cameras, plan, r, config.tour.fps);
            e.policies.push_back(policyRow(policy, budget, w, config.tour));
            step();
        }
    }
    return e;
}

nlohmann::json streamExperimentJson(const StreamExperiment& e) {
    const StreamExperimentConfig& c = e.config;
    nlohmann::json walks = nlohmann::json::array();
    for (const BandwidthRun& run : e.runs) {
        double qualitySum = 0.0;
        for (const stream::FrameReport& f : run.frames) qualitySum += f.quality;
        nlohmann::json at = nlohmann::json::object();
        for (double t : c.shotTimesS) {
            size_t i = size_t(t * c.tour.fps);
            if (i < run.frames.size()) at[fmt::format("{:g}", t)] = run.frames[i].quality;
        }
        walks.push_back(
            {{"bandwidth_kbit", run.kbit},
             {"quality_final", run.qualityFinal},
             {"quality_mean", qualitySum / double(std::max<size_t>(1, run.frames.size()))},
             {"quality_at_s", at},
             {"time_to_quality_90_s", valueOrNull(run.firstAt90S >= 0.0, run.firstAt90S)},
             {"max_resident_bytes", run.maxResidentBytes},
             {"budget_bytes", run.maxBudgetBytes},
             {"moving_budget_bytes", c.budgetBytes},
             {"frames_over_budget", run.framesOverBudget},
             {"downloaded_bytes", run.downloadedBytes},
             {"failed_requests", run.failedRequests}});
    }
    nlohmann::json doc = {{"scene", c.scene},
                          {"cells", e.cells},
                          {"textures", e.textures},
                          {"database_bytes", e.databaseBytes},
                          {"pvs_texture_bytes_max", e.pvsTextureBytesMax},
                          {"all_texture_bytes", e.baseline.textureBytes},
                          {"tour_frames", e.tourFrames},
                          {"tour_s", double(e.tourFrames) / c.tour.fps},
                          {"stop_s", c.tour.stopS},
                          {"size", fmt::format("{}x{}", c.width, c.height)},
                          {"latency_ms", c.latencyS * 1e3},
                          {"walks", walks}};
    for (const BandwidthRun& run : e.runs) {
        if (run.frameMs.empty()) continue;
        doc["frame_time"] = {{"bandwidth_kbit", run.kbit},
                             {"stream_ms_median", median(run.frameMs)},
                             {"stream_ms_p99", percentile(run.frameMs, 0.99)},
                             {"baseline_ms_median", median(e.baseline.frameMs)},
                             {"baseline_ms_p99", percentile(e.baseline.frameMs, 0.99)},
                             {"baseline_load_ms", e.baseline.loadMs},
                             {"baseline_texture_bytes", e.baseline.textureBytes}};
    }
    nlohmann::json policies = nlohmann::json::array();
    for (const PolicyRow& p : e.policies)
        policies.push_back({{"policy", stream::policyName(p.policy)},
                            {"budget_bytes", p.budgetBytes},
                            {"psnr_db", p.psnrDb},
                            {"psnr_after_first_stop_db", p.psnrAfterFirstStopDb},
                            {"psnr_db_median", p.psnrDbMedian},
                            {"frames_compared", p.framesCompared},
                            {"mean_resident_bytes", p.meanResidentBytes},
                            {"max_resident_bytes", p.maxResidentBytes},
                            {"frames_over_budget", p.framesOverBudget},
                            {"downloaded_bytes", p.downloadedBytes},
                            {"quality_final", p.qualityFinal}});
    doc["policy_bandwidth_kbit"] = c.policyKbit;
    doc["policies"] = policies;
    return doc;
}

std::string streamWalksCsv(const StreamExperiment& e) {
    std::string csv =
        "bandwidth_kbit,frame,time_s,budget_bytes,resident_bytes,downloaded_bytes,quality,"
        "frame_ms,baseline_ms\n";
    for (const BandwidthRun& run : e.runs)
        for (size_t i = 0; i < run.frames.size(); ++i) {
            const stream::FrameReport& f = run.frames[i];
            const bool timed = i < run.frameMs.size() && i < e.baseline.frameMs.size();
            csv += fmt::format("{:g},{},{:.4f},{},{},{},{:.4f},{},{}\n", run.kbit, i, f.timeS,
                               f.budgetBytes, f.residentBytes, f.downloadedBytes, f.quality,
                               timed ? fmt::format("{:.3f}", run.frameMs[i]) : "",
                               timed ? fmt::format("{:.3f}", e.baseline.frameMs[i]) : "");
        }
    return csv;
}

std::string streamPoliciesCsv(const StreamExperiment& e) {
    std::string csv =
        "policy,budget_bytes,psnr_db,psnr_after_first_stop_db,psnr_db_median,frames_compared,"
        "mean_resident_bytes,max_resident_bytes,frames_over_budget,downloaded_bytes,"
        "quality_final\n";
    for (const PolicyRow& p : e.policies)
        csv += fmt::format("{},{},{:.3f},{:.3f},{:.3f},{},{:.0f},{},{},{},{:.4f}\n",
                           stream::policyName(p.policy), p.budgetBytes, p.psnrDb,
                           p.psnrAfterFirstStopDb, p.psnrDbMedian, p.framesCompared,
                           p.meanResidentBytes, p.maxResidentBytes, p.framesOverBudget,
                           p.downloadedBytes, p.qualityFinal);
    return csv;
}

std::string streamPolicyFramesCsv(const StreamExperiment& e) {
    const double fps = e.config.tour.fps;
    std::string csv = "policy,budget_bytes,frame,time_s,psnr_db\n";
    for (const PolicyRow& p : e.policies)
        for (const auto& [frame, dB] : p.framePsnrDb)
            csv += fmt::format("{},{},{},{:.4f},{:.3f}\n", stream::policyName(p.policy),
                               p.budgetBytes, frame, double(frame) / fps, dB);
    return csv;
}

std::vector<std::pair<std::string, std::string>> streamPlots(const StreamExperiment& e) {
    constexpr double kMiB = double(1 << 20);
    std::vector<PlotSeries> quality, resident;
    for (const BandwidthRun& run : e.runs) {
        PlotSeries q{bandwidthName(run.kbit), {}}, m{bandwidthName(run.kbit), {}};
        for (size_t i = 0; i < run.frames.size(); i += kPlotStride) {
            q.points.emplace_back(run.frames[i].timeS, 100.0 * run.frames[i].quality);
            m.points.emplace_back(run.frames[i].timeS, double(run.frames[i].residentBytes) / kMiB);
        }
        quality.push_back(std::move(q));
        resident.push_back(std::move(m));
    }
    if (!e.runs.empty()) {
        PlotSeries budget{"budget", {}};
        const BandwidthRun& run = e.runs.front();
        for (size_t i = 0; i < run.frames.size(); i += kPlotStride)
            budget.points.emplace_back(run.frames[i].timeS,
                                       double(run.frames[i].budgetBytes) / kMiB);
        resident.push_back(std::move(budget));
    }
    std::vector<std::pair<std::string, std::string>> plots = {
        {"stream_quality.svg",
         svgLinePlot({"Progressive downloading quality (Fig. 2 top)", "time s", "quality %"},
                     quality)},
        {"stream_resident.svg",
         svgLinePlot({"Resident texture bytes against the budget", "time s", "MiB"}, resident)}};
    for (const BandwidthRun& run : e.runs) {
        if (run.frameMs.empty()) continue;
        // Means over kPlotStride frames (half a second at 30 fps); the CSV has every frame.
        auto means = [&](const std::vector<double>& ms) {
            PlotSeries s;
            for (size_t i = 0; i + kPlotStride <= ms.size(); i += kPlotStride) {
                double sum = 0.0;
                for (size_t k = i; k < i + kPlotStride; ++k) sum += ms[k];
                s.points.emplace_back(run.frames[i].timeS, sum / double(kPlotStride));
            }
            return s;
        };
        PlotSeries streamed = means(run.frameMs), baseline = means(e.baseline.frameMs);
        streamed.name = "streamed (" + bandwidthName(run.kbit) + ")";
        baseline.name = "baseline: every texture at full resolution";
        plots.emplace_back(
            "stream_frame_time.svg",
            svgLinePlot({"Frame time (Fig. 2 bottom), mean of 15 frames", "time s", "ms"},
                        {streamed, baseline}));
    }
    if (!e.policies.empty()) {
        std::map<stream::AllocationPolicy, PlotSeries> series;
        for (const PolicyRow& p : e.policies) {
            PlotSeries& s = series[p.policy];
            s.name = std::string(stream::policyName(p.policy));
            s.points.emplace_back(double(p.budgetBytes) / kMiB, p.psnrDb);
        }
        std::vector<PlotSeries> list;
        for (auto& [policy, s] : series) list.push_back(std::move(s));
        plots.emplace_back("stream_policies.svg",
                           svgLinePlot({"Texture PSNR against full-resolution frames", "budget MiB",
                                        "PSNR dB", false, false},
                                       list));
    }
    return plots;
}

}  // namespace plx::cli
