// parallax bench stereo: Heo, Jung, Wohn Table 1 and Fig. 17 (full pipeline against the P-buffer
// method on office:N), with the reproject method of Fu, Bao, Peng beside them and its paper's
// timing table, as CSV, JSON, markdown and SVG plots.

#include <fmt/format.h>

#include "bench.h"
#include "experiment_stereo.h"

namespace plx::cli {

namespace {

struct StereoBenchArgs {
    std::string out = "out/bench_stereo";
    std::vector<int> rooms{1, 2, 3, 4, 8, 15, 32, 64, 128, 280};
    std::string size = "640x480";
    int frames = 7;
    int threads = 0;
    float separation = 0.065f, convergence = 3.0f;
    bool noConservative = false;
    bool noReproject = false;
    bool json = false;
};

double finiteDb(double db) {
    return std::isfinite(db) ? db : kIdenticalPsnrDb;
}

// The table; the reproject columns only where the run measured them.
void printTable(bool reproject, const std::vector<StereoExperimentRow>& rows) {
    fmt::print("{:>6} {:>9} {:>8} {:>9} {:>9} {:>9} {:>9} {:>8} {:>6}", "rooms", "polygons",
               "visible", "full 1st", "full 2nd", "pbuf 1st", "pbuf 2nd", "speedup", "PSNR");
    if (reproject)
        fmt::print(" {:>9} {:>9} {:>8} {:>6}", "repr 1st", "repr 2nd", "speedup", "PSNR");
    fmt::print("\n");
    for (const auto& r : rows) {
        fmt::print("{:>6} {:>9} {:>8} {:>9.2f} {:>9.2f} {:>9.2f} {:>9.2f} {:>7.2f}x {:>6.1f}",
                   r.rooms, r.polygons, r.visiblePolygons, r.fullFirstMs, r.fullSecondMs,
                   r.pbufferFirstMs, r.pbufferSecondMs + r.collectMs, r.pairSpeedup,
                   finiteDb(r.secondEyePsnrDb));
        if (reproject)
            fmt::print(" {:>9.2f} {:>9.2f} {:>7.2f}x {:>6.1f}", r.reprojectFirstMs,
                       r.reprojectSecondMs, r.reprojectPairSpeedup, finiteDb(r.reprojectPsnrDb));
        fmt::print("\n");
    }
}

int runStereoBench(const StereoBenchArgs& a) {
    auto size = parseSize(a.size);
    if (!size) return fail(size.status().message(), kExitUsage);
    for (int n : a.rooms)
        if (n < 1 || n > 4096)
            return fail(fmt::format("--rooms {} outside 1 .. 4096", n), kExitUsage);
    StereoExperimentConfig config;
    config.rooms = a.rooms;
    config.width = size->x;
    config.height = size->y;
    config.frames = a.frames;
    config.threads = a.threads;
    config.rig.separation = a.separation;
    config.rig.convergence = a.convergence;
    config.conservative = !a.noConservative;
    config.reproject = !a.noReproject;
    if (Status s = checkStereoRigNumbers(config.rig); !s) return fail(s.message(), kExitUsage);
    auto memory = startExperiment(
        "bench stereo", size->x, size->y,
        stereoExperimentImageBytes(config) + stereoExperimentSceneBytes(config), a.out);
    if (!memory) return fail(memory.status());
    Progress progress("bench stereo", a.rooms.size());
    auto rows = runStereoExperiment(config, [&](size_t, size_t) { progress.step(); });
    if (!rows) return fail(rows.status());
    nlohmann::json doc = stereoExperimentJson(config, *rows);
    doc.update(memoryJson(*memory));
    auto files = stereoPlots(*rows);
    files.emplace_back("table1.csv", stereoExperimentCsv(config, *rows));
    if (config.reproject) {
        files.emplace_back("methods.md", stereoMethodsMarkdown(*rows));
        files.emplace_back("reproject_paper_table.md", reprojectPaperTableMarkdown(*rows));
    }
    return finishExperiment(
        a.out, a.json, doc, "table1.json", std::move(files), [&](const std::string& dir) {
            printTable(config.reproject, *rows);
            fmt::print(
                "times in ms per eye (median of {} frames); wrote "
                "{}table1.{{csv,json}}{} and Fig. 17 SVG plots\n",
                a.frames, dir, config.reproject ? ", methods.md, reproject_paper_table.md" : "");
        });
}

}  // namespace

Command addBenchStereo(CLI::App* bench) {
    auto a = std::make_shared<StereoBenchArgs>();
    CLI::App* sub = bench->add_subcommand(
        "stereo",
        "Heo, Jung, Wohn Table 1 and Fig. 17: full vs P-buffer vs reproject stereo on "
        "office:N");
    sub->footer(
        "Example: parallax bench stereo --rooms 1,4,16,64,280 --size 640x480\n"
        "         parallax bench stereo --rooms 3,8,32,128,280 --size 1280x720 --threads 2 "
        "--frames 9 --out out/bench_stereo_720");
    sub->add_option("--rooms", a->rooms, "Office rooms per row of the table")->delimiter(',');
    sub->add_option("--size", a->size, "Image size WxH")->capture_default_str();
    sub->add_option("--frames", a->frames, "Timed frames per method (median)")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    sub->add_option("--threads", a->threads, "Worker threads (0: all cores)")
        ->check(CLI::Range(0, 1024));
    sub->add_option("--separation", a->separation, "Eye separation e (m)")
        ->capture_default_str()
        ->check(floatNumber());
    sub->add_option("--convergence", a->convergence, "Convergence distance c (m)")
        ->capture_default_str()
        ->check(floatNumber());
    sub->add_flag("--no-conservative", a->noConservative, "Skip the conservative-set columns");
    sub->add_flag("--no-reproject", a->noReproject, "Skip the reproject-method columns");
    sub->add_option("--out", a->out, "Output folder")
        ->capture_default_str()
        ->check(outputPath(OutputKind::kFolder));
    sub->add_flag("--json", a->json, "Print the table as JSON");
    return {sub, [a] { return runStereoBench(*a); }};
}

}  // namespace plx::cli
