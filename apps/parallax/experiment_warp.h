#pragma once
// The latency experiment of Mark, Bishop, McMillan ("Latency and Remote Display", "Prediction
// techniques"), simulated deterministically on one machine: a head walks a camera path, a
// display shows a frame every 1/60 s, and a render server far away answers pose requests one
// round trip (RTT) later. Per display frame each method's image is compared with the render at
// the current pose. Also the warp's throughput against output size, thread count and scene
// size. Typed rows; JSON, CSV and plots are made from them.

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <plx/scene/scene.h>
#include <plx/warp/holes.h>
#include <plx/warp/warp.h>

namespace plx::cli {

// What the display shows at each frame, from the newest reference that has arrived.
enum class LatencyMethod {
    kStale,           // the display-sized frame rendered for the request's pose, shown as is
    kTimewarp,        // that frame, rotation-only timewarped to the current pose
    kWarp1,           // the newest reference set warped to the current pose
    kWarp2,           // the newest two reference sets, composited by depth
    kWarp2Predicted,  // two sets requested for constant-velocity predicted poses (now + RTT)
    // Both sets of the newest request, for the predicted poses at its arrival (now + RTT) and
    // at the next one's (now + RTT + refresh): they bracket the poses shown until the next
    // pair arrives.
    kWarp2Bracketed,
};
inline constexpr LatencyMethod kLatencyMethods[] = {
    LatencyMethod::kStale, LatencyMethod::kTimewarp,       LatencyMethod::kWarp1,
    LatencyMethod::kWarp2, LatencyMethod::kWarp2Predicted, LatencyMethod::kWarp2Bracketed};
const char* latencyMethodName(LatencyMethod method);  // stale, timewarp, warp1, warp2, ...

struct WarpExperimentConfig {
    // Walkthroughs (stereo::builtinWalk) through generated scenes; a model file (an orbit
    // around it) is added when modelPath names one that exists, else skipped with a note.
    std::vector<std::string> scenes{"office:8", "museum:4"};
    std::string modelPath;
    std::vector<double> rttsMs{0, 50, 100, 200, 300, 500};
    double refreshMs = 100.0;  // the client requests a new reference set this often
    double displayHz = 60.0;
    double durationS = 2.0;         // measured display time per scene (after the path's lead-in)
    int width = 320, height = 240;  // the display (the paper's 320x240)
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;
    warp::Splat splat = warp::Splat::kDerivative;
    float compositeTolerance = warp::kCompositeTolerance;  // WarpOptions::compositeTolerance
    int threads = 0;
    // Throughput table: output sizes x thread counts on one scene, and the scenes of the
    // size-independence check at the first output size.
    std::vector<std::pair<int, int>> throughputSizes{{320, 240}, {640, 480}, {1280, 720}};
    std::vector<int> throughputThreads{1, 2};
    std::string throughputScene = "office:8";
    std::vector<std::string> sizeScenes{"office:1", "office:280"};
    int throughputFrames = 9;  // timed warps per row (median), after one warm-up
};

// Medians over the measured display frames of one scene, method and RTT.
struct LatencyRow {
    std::string scene;
    LatencyMethod method = LatencyMethod::kStale;
    double rttMs = 0.0;
    int frames = 0;
    double psnrDbMedian = 0.0;        // against the render at the current pose; 99 for identical
    double holeFractionMedian = 0.0;  // pixels no source covered (before any fill)
    std::optional<double> warpMsMedian;  // client-side cost per frame (none for the stale frame)
};

struct ThroughputRow {
    std::string scene;
    size_t triangles = 0;
    int width = 0, height = 0, threads = 0, faceSize = 0;
    int64_t sourcePixels = 0;  // every pixel of the reference set
    int64_t warpedPixels = 0;  // those left after row clipping
    double warpMs = 0.0;       // median
    double mpixPerS = 0.0;     // source pixels per second (all of the set: the module's measure)
};

struct WarpExperiment {
    WarpExperimentConfig config;
    std::vector<LatencyRow> latency;
    std::vector<ThroughputRow> throughput;
    std::vector<std::string> notes;  // scenes skipped and why
};

// Reference-set options for a display camera: cube faces (or the wide view) at the display's
// pixel density (the paper's 416-pixel faces for 320x240 at 60 degrees), clip planes from the
// scene's bounds.
warp::ReferenceSetOptions referenceOptionsFor(const scene::Scene& scene, const Camera& display,
                                              warp::ReferenceLayout layout);
// The same without the scene: layout, face size (and wide field of view) only; default planes.
warp::ReferenceSetOptions referenceDensityFor(const Camera& display, warp::ReferenceLayout layout);

// Pixels of every view of a set: the "source pixels" of Mpix/s figures, clipped rows included.
int64_t referencePixels(const warp::ReferenceSet& set);
// The same for the set `options` give, before it is rendered (memory estimates).
Result<int64_t> referencePixels(const warp::ReferenceSetOptions& options);
// A display of width x height with the scenes' 60-degree field of view (memory estimates).
Result<Camera> displayOfSize(int width, int height);

// The pose a display camera looks from.
warp::Pose poseOf(const Camera& camera);

// One display frame of the latency experiment kept as images: the render at the current pose
// and each method's frame, with their PSNR and hole fraction.
struct LatencyExample {
    struct Shown {
        LatencyMethod method;
        Image<Rgba8> image;
        double psnrDb = 0.0, holeFraction = 0.0;
    };
    Image<Rgba8> truth;
    std::vector<Shown> images;  // in kLatencyMethods order
};

// The example at display frame `frame` (counted from the first measured frame) of a walkthrough
// of a generated scene, for one RTT. Errors: as runWarpExperiment.
Result<LatencyExample> latencyExample(const std::string& scene, const WarpExperimentConfig& config,
                                      double rttMs, int frame);

// Errors: an empty RTT list, an RTT outside 0 .. 10 s, refresh, display rate, duration or a size
// out of range, no throughput frames.
Status checkWarpExperimentConfig(const WarpExperimentConfig& config);

// The experiment's peak bytes, for checkImageMemory: the most reference sets and answer frames
// the latency simulation holds, once it has run for the longest RTT, with its largest generated
// scene, or a throughput row's set with its scene (the throughput scene; at the first size also
// each size row's), whichever is more, and the renderer grown for the largest scene so far (the
// scenes are loaded one at a time). Errors: a size no camera takes, a bad scene spec.
Result<double> warpExperimentBytes(const WarpExperimentConfig& config);

// Runs the latency experiment and the throughput table; progress(done, total) after each step.
// Errors: those of checkWarpExperimentConfig, a scene that does not load.
Result<WarpExperiment> runWarpExperiment(
    const WarpExperimentConfig& config,
    const std::function<void(size_t, size_t)>& progress = nullptr);

// {"width", "height", "refresh_ms", ..., "rows": [{"scene", "method", "rtt_ms",
// "psnr_db_median", "hole_fraction_median", "warp_ms_median", "frames"}], "throughput": [...],
// "notes": [...]}: the document `parallax bench warp --json` prints.
nlohmann::json warpExperimentJson(const WarpExperiment& experiment);
// The latency rows as CSV (one header line), and the throughput rows.
std::string latencyCsv(const WarpExperiment& experiment);
std::string throughputCsv(const WarpExperiment& experiment);

// PSNR against RTT, one series per method, one plot per scene; hole fraction likewise; warp
// throughput against output size. (file name, SVG) pairs.
std::vector<std::pair<std::string, std::string>> warpPlots(const WarpExperiment& experiment);

}  // namespace plx::cli
