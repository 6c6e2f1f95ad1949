// parallax bench warp: Mark, Bishop, McMillan's latency compensation measured: stale frames,
// rotation-only timewarp and the post-rendering warp against the round-trip time, plus the
// warp's throughput, as CSV, JSON and SVG plots.

#include <optional>

#include <fmt/format.h>

#include "bench.h"
#include "experiment_warp.h"

namespace plx::cli {
namespace {

struct WarpBenchArgs {
    std::string out = "out/bench_warp";
    std::vector<std::string> scenes;
    std::vector<double> rttsMs;
    std::string size;
    double refreshMs = 100.0;
    float compositeTolerance = warp::kCompositeTolerance;
    std::optional<double> durationS;  // unset: the configuration's (warpBaseConfig)
    std::string refs = "cube4";
    std::string splat = "derivative";
    std::vector<int> warpThreads;
    int threads = 0;
    bool noModel = false;
    bool quick = false;
    bool json = false;
};

// The quick configuration runs in seconds (tests, CI); the default one makes the docs' tables.
WarpExperimentConfig warpBaseConfig(bool quick) {
    WarpExperimentConfig c;
    c.modelPath = std::string(PLX_SHARED_DATA_DIR) + "/models/DamagedHelmet/DamagedHelmet.glb";
    if (!quick) return c;
    c.scenes = {"office:2"};
    c.modelPath.clear();
    c.rttsMs = {0, 100, 300};
    c.durationS = 0.1;
    c.width = 96;
    c.height = 72;
    c.throughputSizes = {{96, 72}, {160, 120}};
    c.throughputThreads = {1};
    c.throughputScene = "office:2";
    c.sizeScenes = {"office:1", "office:4"};
    c.throughputFrames = 2;
    return c;
}

Result<WarpExperimentConfig> configFrom(const WarpBenchArgs& a) {
    WarpExperimentConfig c = warpBaseConfig(a.quick);
    if (!a.scenes.empty()) c.scenes = a.scenes;
    if (!a.rttsMs.empty()) c.rttsMs = a.rttsMs;
    if (!a.size.empty()) {
        auto size = parseSize(a.size);
        if (!size) return size.status();
        c.width = size->x;
        c.height = size->y;
    }
    if (a.durationS) c.durationS = *a.durationS;
    c.refreshMs = a.refreshMs;
    if (!(a.compositeTolerance >= 0.0f && a.compositeTolerance <= 1e6f))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("--composite-tolerance {} outside 0 .. 1e6", a.compositeTolerance));
    c.compositeTolerance = a.compositeTolerance;
    auto layout = warp::parseReferenceLayout(a.refs);
    if (!layout) return layout.status();
    c.layout = *layout;
    auto splat = warp::parseSplat(a.splat);
    if (!splat) return splat.status();
    c.splat = *splat;
    if (!a.warpThreads.empty()) c.throughputThreads = a.warpThreads;
    for (int t : c.throughputThreads)
        if (t < 1 || t > 1024)
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("--warp-threads {} outside 1 .. 1024", t));
    c.threads = a.threads;
    if (a.noModel) c.modelPath.clear();
    PLX_RETURN_IF_ERROR(checkWarpExperimentConfig(c));
    return c;
}

void printTables(const WarpExperiment& e, const std::string& dir) {
    fmt::print("{:<12} {:<16} {:>7} {:>9} {:>9} {:>9}\n", "scene", "method", "RTT ms", "PSNR dB",
               "holes %", "warp ms");
    for (const LatencyRow& r : e.latency)
        fmt::print("{:<12} {:<16} {:>7g} {:>9.2f} {:>9.3f} {:>9}\n", r.scene,
                   latencyMethodName(r.method), r.rttMs, r.psnrDbMedian,
                   100.0 * r.holeFractionMedian, figureOrEmpty(r.warpMsMedian, "{:.2f}", "-"));
    fmt::print("\n{:<12} {:>9} {:>10} {:>8} {:>6} {:>10} {:>9} {:>8}\n", "scene", "triangles",
               "output", "threads", "face", "source px", "warp ms", "Mpix/s");
    for (const ThroughputRow& r : e.throughput)
        fmt::print("{:<12} {:>9} {:>10} {:>8} {:>6} {:>10} {:>9.2f} {:>8.1f}\n", r.scene,
                   r.triangles, fmt::format("{}x{}", r.width, r.height), r.threads, r.faceSize,
                   r.sourcePixels, r.warpMs, r.mpixPerS);
    for (const std::string& note : e.notes) fmt::print("note: {}\n", note);
    fmt::print(
        "medians over {:g} s of 60 Hz frames per scene; wrote {}latency.csv, "
        "throughput.csv, warp.json and SVG plots\n",
        e.config.durationS, dir);
}

int runWarpBench(const WarpBenchArgs& a) {
    auto config = configFrom(a);
    if (!config) return fail(config.status().message(), kExitUsage);
    auto bytes = warpExperimentBytes(*config);
    if (!bytes) return fail(bytes.status().message(), kExitUsage);
    auto memory = startExperiment("bench warp", config->width, config->height, *bytes, a.out);
    if (!memory) return fail(memory.status());
    StepProgress progress("bench warp");
    auto e = runWarpExperiment(*config, progress.callback());
    if (!e) return fail(e.status());
    auto files = warpPlots(*e);
    files.emplace_back("latency.csv", latencyCsv(*e));
    files.emplace_back("throughput.csv", throughputCsv(*e));
    nlohmann::json doc = warpExperimentJson(*e);
    doc.update(memoryJson(*memory));
    return finishExperiment(a.out, a.json, doc, "warp.json", std::move(files),
                            [&](const std::string& dir) { printTables(*e, dir); });
}

}  // namespace

Command addBenchWarp(CLI::App* bench) {
    auto a = std::make_shared<WarpBenchArgs>();
    CLI::App* sub = bench->add_subcommand(
        "warp", "Mark, Bishop, McMillan: stale, timewarp and warped frames against the RTT");
    sub->footer(
        "Example: parallax bench warp --quick --json\n         parallax bench warp "
        "--scenes office:8 --rtts 0,100,300 --size 320x240");
    sub->add_option("--scenes", a->scenes, "Walkthrough scenes (default office:8,museum:4)")
        ->delimiter(',');
    sub->add_option("--rtts", a->rttsMs, "Round-trip times in ms (default 0,50,100,200,300,500)")
        ->delimiter(',');
    sub->add_option("--size", a->size, "Display size WxH (default 320x240)");
    sub->add_option("--composite-tolerance", a->compositeTolerance,
                    "Relative 1/w margin by which a set other than the nearest must be nearer to "
                    "win a pixel (0: plain z-buffer)")
        ->check(floatNumber());
    sub->add_option("--refresh", a->refreshMs, "Reference request interval in ms")
        ->capture_default_str();
    sub->add_option("--duration", a->durationS,
                    "Measured seconds of display per scene (default 2)");
    sub->add_option("--refs", a->refs, "cube4 | cube6 | wide")->capture_default_str();
    sub->add_option("--splat", a->splat, "derivative | point | fixed | mesh")
        ->capture_default_str();
    sub->add_option("--warp-threads", a->warpThreads, "Thread counts of the throughput table")
        ->delimiter(',');
    sub->add_option("--threads", a->threads, "Worker threads elsewhere (0: all cores)")
        ->check(CLI::Range(0, 1024));
    sub->add_flag("--no-model", a->noModel, "Skip the shared data's model");
    sub->add_flag("--quick", a->quick, "One small scene, three RTTs, a few frames (for tests)");
    sub->add_option("--out", a->out, "Output folder")
        ->capture_default_str()
        ->check(outputPath(OutputKind::kFolder));
    sub->add_flag("--json", a->json, "Print the tables as JSON");
    return {sub, [a] { return runWarpBench(*a); }};
}

}  // namespace plx::cli
