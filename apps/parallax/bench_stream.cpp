// parallax bench stream: Marvie & Bouatouch section 7 on the deterministic link simulator (the
// tour through every room at four bandwidths, frame time against a full-resolution baseline) and,
// beyond the paper, the ACH allocation against LRU and an equal split at equal budgets, as CSV,
// JSON, SVG plots and the Fig. 3 frames.

#include <cmath>
#include <optional>

#include <fmt/format.h>

#include <plx/core/image_io.h>

#include "bench.h"
#include "experiment_stream.h"

namespace plx::cli {
namespace {

struct StreamBenchArgs {
    std::string out = "out/bench_stream";
    std::string scene;
    std::vector<double> bandwidthsKbit;
    std::vector<double> policyBudgetsMb;
    // Unset: the configuration's default (streamBaseConfig).
    std::optional<double> budgetMb, staticBudgetMb;
    double policyKbit = 0.0;
    std::optional<double> latencyMs;
    std::optional<double> stopS;
    std::optional<int> samples;
    int psnrEvery = 0;
    std::string size;
    int threads = 0;
    bool noFrameTimes = false;
    bool quick = false;
    bool json = false;
};

constexpr double kMaxBudgetMb = 1 << 20;  // 1 TiB: beyond any graphics memory

// The quick configuration runs in seconds (tests, CI); the default one makes the docs' tables.
StreamExperimentConfig streamBaseConfig(bool quick) {
    StreamExperimentConfig c;
    if (!quick) return c;
    c.scene = "museum:4";
    c.sampling.samples = 2;
    c.sampling.faceSize = 32;
    c.width = 96, c.height = 72;
    c.tour.stopS = 2.0;
    c.policyBudgets = {uint64_t(128) << 10, uint64_t(256) << 10};
    c.psnrEvery = 30;
    return c;
}

Status checkMb(const char* name, double mb) {
    if (std::isfinite(mb) && mb > 0.0 && mb <= kMaxBudgetMb) return Status::ok();
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("{} {} outside (0, {}] MB", name, mb, kMaxBudgetMb));
}

Result<StreamExperimentConfig> configFrom(const StreamBenchArgs& a) {
    StreamExperimentConfig c = streamBaseConfig(a.quick);
    if (!a.scene.empty()) c.scene = a.scene;
    if (!a.bandwidthsKbit.empty()) c.bandwidthsKbit = a.bandwidthsKbit;
    if (a.budgetMb) {
        PLX_RETURN_IF_ERROR(checkMb("--budget", *a.budgetMb));
        c.budgetBytes = mebibytes(*a.budgetMb);
    }
    if (a.staticBudgetMb) {
        PLX_RETURN_IF_ERROR(checkMb("--static-budget", *a.staticBudgetMb));
        c.staticBudgetBytes = mebibytes(*a.staticBudgetMb);
    }
    if (!a.policyBudgetsMb.empty()) {
        c.policyBudgets.clear();
        for (double mb : a.policyBudgetsMb) {
            PLX_RETURN_IF_ERROR(checkMb("--policy-budgets", mb));
            c.policyBudgets.push_back(mebibytes(mb));
        }
    }
    c.policyKbit = a.policyKbit;
    if (a.latencyMs) c.latencyS = *a.latencyMs * 1e-3;
    if (a.stopS) {
        if (!(*a.stopS >= 0.0 && *a.stopS <= 3600.0))
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("--stop {} outside 0 .. 3600", *a.stopS));
        c.tour.stopS = *a.stopS;
    }
    if (a.samples) {
        if (*a.samples < 1 || *a.samples > 1024)
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("--samples {} outside 1 .. 1024", *a.samples));
        c.sampling.samples = *a.samples;
    }
    if (a.psnrEvery != 0) c.psnrEvery = a.psnrEvery;
    if (!a.size.empty()) {
        auto size = parseSize(a.size);
        if (!size) return size.status();
        c.width = size->x, c.height = size->y;
    }
    if (a.noFrameTimes) c.frameTimes = false;
    c.threads = a.threads;
    c.dbDir = a.out + "/db";
    PLX_RETURN_IF_ERROR(checkStreamExperimentConfig(c));
    return c;
}

void printTables(const StreamExperiment& e, const std::string& dir) {
    fmt::print("{} ({}, {}, {:.1f} MB), tour of {} ({:.0f} s)\n", e.config.scene,
               counted(e.cells, "cell"), counted(e.textures, "texture"),
               double(e.databaseBytes) / 1e6, counted(e.tourFrames, "frame"),
               double(e.tourFrames) / e.config.tour.fps);
    fmt::print("{:<12} {:>9} {:>9} {:>14} {:>14} {:>6} {:>11}\n", "link", "final q %", "q>=90% s",
               "max resident", "budget", "over", "downloaded");
    for (const BandwidthRun& r : e.runs)
        fmt::print("{:<12} {:>9.1f} {:>9} {:>14} {:>14} {:>6} {:>11}\n", bandwidthName(r.kbit),
                   100.0 * r.qualityFinal,
                   r.firstAt90S < 0.0 ? "never" : fmt::format("{:.1f}", r.firstAt90S),
                   r.maxResidentBytes, r.maxBudgetBytes, r.framesOverBudget, r.downloadedBytes);
    nlohmann::json doc = streamExperimentJson(e);
    if (doc.contains("frame_time")) {
        const auto& f = doc["frame_time"];
        fmt::print(
            "\nframe ms (median / p99): streamed {:.2f} / {:.2f}, baseline {:.2f} / {:.2f}; "
            "baseline loads {} texture bytes in {:.0f} ms\n",
            f["stream_ms_median"].get<double>(), f["stream_ms_p99"].get<double>(),
            f["baseline_ms_median"].get<double>(), f["baseline_ms_p99"].get<double>(),
            f["baseline_texture_bytes"].get<uint64_t>(), f["baseline_load_ms"].get<double>());
    }
    fmt::print("\n{:<11} {:>12} {:>9} {:>11} {:>11} {:>8} {:>14} {:>14}\n", "policy", "budget",
               "PSNR dB", "walk dB", "median dB", "frames", "mean resident", "max resident");
    for (const PolicyRow& p : e.policies)
        fmt::print("{:<11} {:>12} {:>9.2f} {:>11.2f} {:>11.2f} {:>8} {:>14.0f} {:>14}\n",
                   stream::policyName(p.policy), p.budgetBytes, p.psnrDb, p.psnrAfterFirstStopDb,
                   p.psnrDbMedian, p.framesCompared, p.meanResidentBytes, p.maxResidentBytes);
    fmt::print(
        "largest room PVS: {} texel bytes at full resolution; wrote {}walks.csv, policies.csv, "
        "policy_frames.csv, stream.json, SVG plots and frames\n",
        e.pvsTextureBytesMax, dir);
}

int runStreamBench(const StreamBenchArgs& a) {
    auto config = configFrom(a);
    if (!config) return fail(config.status().message(), kExitUsage);
    if (Status s = createOutputFolder(a.out); !s) return fail(s);
    StepProgress progress("bench stream");
    auto e = runStreamExperiment(*config, progress.callback());
    if (!e) return fail(e.status());
    const std::string dir = a.out + "/";
    for (const BandwidthRun& run : e->runs)
        for (const auto& [timeS, image] : run.shots)
            if (Status s = writePng(fmt::format("{}stream_{:02}s.png", dir, int(timeS)), image); !s)
                return fail(s);
    if (!e->fullShot.empty())
        if (Status s = writePng(dir + "stream_full.png", e->fullShot); !s) return fail(s);
    auto files = streamPlots(*e);
    files.emplace_back("walks.csv", streamWalksCsv(*e));
    files.emplace_back("policies.csv", streamPoliciesCsv(*e));
    files.emplace_back("policy_frames.csv", streamPolicyFramesCsv(*e));
    nlohmann::json doc = streamExperimentJson(*e);
    doc.update(memoryJson(e->memoryEstimateBytes));
    return finishExperiment(a.out, a.json, doc, "stream.json", std::move(files),
                            [&](const std::string&) { printTables(*e, dir); });
}

}  // namespace

Command addBenchStream(CLI::App* bench) {
    auto a = std::make_shared<StreamBenchArgs>();
    CLI::App* sub = bench->add_subcommand(
        "stream", "Marvie, Bouatouch: texture streaming walks, frame time, allocation policies");
    sub->footer(
        "Example: parallax bench stream --quick --json\n"
        "         parallax bench stream --scene museum:16 --bandwidths 56,1000,10000,0\n"
        "Builds the database under OUT/db, walks the tour through every room (stream walk "
        "--tour) at each bandwidth with the --budget / --static-budget pair (Fig. 2), renders "
        "every frame of the unlimited walk and of a baseline holding every texture at full "
        "resolution, and walks it again with each allocation policy (ach, ach-return, ach-texture, "
        "lru, equal) "
        "at each --policy-budgets value (moving and still alike), comparing every --psnr-every-th "
        "frame "
        "with the same frame at full texture resolution.\n"
        "JSON: walks [{bandwidth_kbit, quality_final, time_to_quality_90_s, max_resident_bytes, "
        "budget_bytes, ...}], frame_time {...}, policies [{policy, budget_bytes, psnr_db, ...}].");
    sub->add_option("--scene", a->scene,
                    "Scene spec (default museum:16); the tour visits its rooms, or its kd cells "
                    "when it has none");
    sub->add_option("--bandwidths", a->bandwidthsKbit,
                    "Link bandwidths in kbit/s, 0 unlimited (default 56,1000,10000,0)")
        ->delimiter(',');
    sub->add_option("--budget", a->budgetMb, "Moving budget M^mem of the walks, MB (default 1)");
    sub->add_option("--static-budget", a->staticBudgetMb,
                    "Static budget M^mem_static of the walks, MB (default 4)");
    sub->add_option("--policy-budgets", a->policyBudgetsMb,
                    "Budgets of the policy comparison, MB (default 0.5,1,2,4)")
        ->delimiter(',');
    sub->add_option("--policy-bandwidth", a->policyKbit,
                    "Link of the policy comparison, kbit/s (0: unlimited)")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1e7));
    sub->add_option("--latency", a->latencyMs, "Latency per request, ms (default 50)")
        ->check(floatNumber())
        ->check(CLI::Range(0.0, 10000.0));
    sub->add_option("--stop", a->stopS, "Seconds standing still in each room (default 10)");
    sub->add_option("--samples", a->samples, "PVS samples per cell (default 8)");
    sub->add_option("--psnr-every", a->psnrEvery, "Compare every Nth frame (default 30)")
        ->check(CLI::Range(1, 100000));
    sub->add_option("--size", a->size, "Frame size WxH (default 320x240)");
    sub->add_option("--threads", a->threads, "Worker threads (0: all cores)")
        ->check(CLI::Range(0, 1024));
    sub->add_flag("--no-frame-times", a->noFrameTimes,
                  "Skip rendering every frame of the unlimited walk and the baseline");
    sub->add_flag("--quick", a->quick, "museum:4, coarse sampling, small frames (for tests)");
    sub->add_option("--out", a->out, "Output folder")
        ->capture_default_str()
        ->check(outputPath(OutputKind::kFolder));
    sub->add_flag("--json", a->json, "Print the tables as JSON");
    return {sub, [a] { return runStreamBench(*a); }};
}

}  // namespace plx::cli
