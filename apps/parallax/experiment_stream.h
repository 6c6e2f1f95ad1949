#pragma once
// The texture-streaming experiments of Marvie & Bouatouch section 7, run on the deterministic
// link simulator: a database built from a generated museum, a tour through every room
// (stream::roomTour) walked at several bandwidths (Fig. 2 top: progressive downloading quality
// over time, resident bytes against the budget); the frame time of the streamed walk against a
// baseline holding every texture at full resolution (Fig. 2 bottom); and, beyond the paper, the
// ACH allocation against LRU and an equal split at equal budgets, judged by the PSNR of the
// frames against the same frames with every texture at full resolution. Shared by
// `parallax bench stream` and the demo; typed rows, with JSON, CSV and plots made from them.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <plx/core/image.h>
#include <plx/stream/budget.h>
#include <plx/stream/client.h>
#include <plx/stream/tour.h>
#include <plx/stream/visibility.h>

namespace plx::cli {

struct StreamExperimentConfig {
    std::string scene = "museum:16";
    stream::VisibilityConfig sampling;  // the paper's eight samples per cell
    std::string dbDir;                  // where the database is built (required)
    int width = 320, height = 240;
    stream::TourConfig tour;  // through every room, stopping 10 s in each
    double latencyS = 0.05;   // per request, on every simulated link
    // The walks of Fig. 2, kbit/s (0: unlimited), under the paper's two budgets (scaled to the
    // generated museum: its rooms hold about 1/20 of the paper's texture bytes).
    std::vector<double> bandwidthsKbit{56, 1000, 10000, 0};
    uint64_t budgetBytes = uint64_t(1) << 20;
    uint64_t staticBudgetBytes = uint64_t(4) << 20;
    // Render every frame of the unlimited walk and of the full-resolution baseline (Fig. 2
    // bottom); off, only the screenshots are rendered.
    bool frameTimes = true;
    // Frames of the slowest walk written at these simulated times (Fig. 3).
    std::vector<double> shotTimesS{10.0, 35.0, 80.0};
    // The allocation comparison: each policy at each budget (the same budget moving and
    // still), on a link of policyKbit, comparing every psnrEvery-th frame.
    std::vector<stream::AllocationPolicy> policies{
        stream::AllocationPolicy::kAch, stream::AllocationPolicy::kAchReturn,
        stream::AllocationPolicy::kAchTexture, stream::AllocationPolicy::kLru,
        stream::AllocationPolicy::kEqualSplit};
    std::vector<uint64_t> policyBudgets{uint64_t(512) << 10, uint64_t(1) << 20, uint64_t(2) << 20,
                                        uint64_t(4) << 20};
    double policyKbit = 0.0;
    int psnrEvery = 30;
    int threads = 0;  // renderer and preprocessing threads (0: all cores)
};

// One walk of Fig. 2.
struct BandwidthRun {
    double kbit = 0.0;  // 0: unlimited
    std::vector<stream::FrameReport> frames;
    std::vector<double> frameMs;  // client step + scene + render per frame (frameTimes only)
    double qualityFinal = 0.0;
    double firstAt90S = -1.0;  // first time quality >= 90%, -1: never
    uint64_t maxResidentBytes = 0;
    uint64_t maxBudgetBytes = 0;  // the larger of the two budgets (the static one)
    int framesOverBudget = 0;     // frames whose resident bytes exceeded that frame's budget
    uint64_t downloadedBytes = 0;
    uint64_t failedRequests = 0;
    std::vector<std::pair<double, Image<Rgba8>>> shots;  // (simulated s, frame)
};

// The full-resolution baseline of Fig. 2 bottom: the whole scene with every texture at full
// resolution (the generated scene's, which the lossless PTM files decode to), no budget.
struct BaselineRun {
    std::vector<double> frameMs;  // render per frame
    double loadMs = 0.0;          // decoding every PTM file of the database, with mip chains
    uint64_t textureBytes = 0;    // resident texel bytes (every texture, full chain)
};

// One policy at one budget.
struct PolicyRow {
    stream::AllocationPolicy policy = stream::AllocationPolicy::kAch;
    uint64_t budgetBytes = 0;
    int framesCompared = 0;
    double psnrDb = 0.0;        // over all compared frames: from their mean squared error
    // The same over the frames after the tour's first stop (t >= stopS): the start-up load in
    // the first room, bound by the link and the same under every policy, left out.
    double psnrAfterFirstStopDb = 0.0;
    double psnrDbMedian = 0.0;  // median of the frames' PSNR (99 for identical frames)
    double meanResidentBytes = 0.0;
    uint64_t maxResidentBytes = 0;
    int framesOverBudget = 0;
    uint64_t downloadedBytes = 0;
    double qualityFinal = 0.0;
    std::vector<std::pair<size_t, double>> framePsnrDb;  // (frame, PSNR) of each compared frame
};

struct StreamExperiment {
    StreamExperimentConfig config;
    size_t cells = 0, textures = 0, tourFrames = 0;
    uint64_t databaseBytes = 0;
    uint64_t pvsTextureBytesMax = 0;  // largest full-resolution texel bytes of one room's PVS
    std::vector<BandwidthRun> runs;   // in config.bandwidthsKbit order
    BaselineRun baseline;             // frame times with frameTimes only
    Image<Rgba8> fullShot;            // the baseline at the slowest walk's last shot (Fig. 3)
    std::vector<PolicyRow> policies;  // budgets outer, policies inner
    uint64_t memoryEstimateBytes = 0;  // the peak checkImageMemory estimated, for memoryJson
};

// Errors: no bandwidths, a bandwidth outside 0 .. 1e7 kbit/s, latency outside 0 .. 10 s, a zero
// budget, an empty dbDir, psnrEvery < 1, a size outside 16 .. 4096.
Status checkStreamExperimentConfig(const StreamExperimentConfig& config);

// Builds the database and runs the walks; progress(done, total) after each step. Errors: those
// of checkStreamExperimentConfig, a scene that does not load, more memory than the process can
// take once the museum is generated (checkImageMemory), a database that cannot be written.
Result<StreamExperiment> runStreamExperiment(
    const StreamExperimentConfig& config,
    const std::function<void(size_t, size_t)>& progress = nullptr);

// {"scene", "cells", ..., "walks": [{"bandwidth_kbit", "quality_final", "time_to_quality_90_s",
// "max_resident_bytes", "budget_bytes", ...}], "frame_time": {...}, "policies": [...]}: the
// document `parallax bench stream --json` prints.
nlohmann::json streamExperimentJson(const StreamExperiment& experiment);
// Per-frame rows of every walk (walk, frame, time, budget, resident, downloaded, quality, frame
// ms), the baseline's frame times, and the policy rows, as CSV.
std::string streamWalksCsv(const StreamExperiment& experiment);
std::string streamPoliciesCsv(const StreamExperiment& experiment);
// Every compared frame of the policy walks: policy, budget, frame, time, PSNR.
std::string streamPolicyFramesCsv(const StreamExperiment& experiment);

// Quality over time (Fig. 2 top), resident bytes against the budget, frame time against the
// baseline (Fig. 2 bottom), PSNR against budget per policy: (file name, SVG) pairs.
std::vector<std::pair<std::string, std::string>> streamPlots(const StreamExperiment& experiment);

// "56 kbit/s", "1 Mbit/s", "unlimited".
std::string bandwidthName(double kbit);

}  // namespace plx::cli
