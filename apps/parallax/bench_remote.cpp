// parallax bench remote: Mark, Bishop, McMillan's remote rendering system measured over real
// sockets (experiment_remote.h): a render server and a warping client in this process over
// loopback, the link emulated by the server, against plain video streaming and rotation-only
// timewarp, as CSV, JSON and SVG plots.

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "bench.h"
#include "experiment_remote.h"

namespace plx::cli {
namespace {

struct RemoteBenchArgs {
    std::string out = "out/bench_remote";
    std::vector<std::string> scenes;
    std::vector<double> rttsMs;
    std::vector<double> bandwidthsMbit;
    std::string size;
    double durationS = 0.0;
    std::string refs = "cube4";
    int threads = 0;
    bool quick = false;
    bool json = false;
};

// The quick configuration runs in seconds (tests); the default one makes the docs' table.
RemoteExperimentConfig remoteBaseConfig(bool quick) {
    RemoteExperimentConfig c;
    if (!quick) return c;
    c.scenes = {"office:2"};
    c.links = {{0, 1000}, {100, 1000}};
    c.width = 96;
    c.height = 72;
    c.leadInS = 0.5;
    c.durationS = 0.5;
    return c;
}

Result<RemoteExperimentConfig> configFrom(const RemoteBenchArgs& a) {
    RemoteExperimentConfig c = remoteBaseConfig(a.quick);
    if (!a.scenes.empty()) c.scenes = a.scenes;
    // --rtts sweeps at the first --bandwidths (default 1000); the other bandwidths are run at
    // RTT 100 ms, as the default does.
    if (!a.rttsMs.empty() || !a.bandwidthsMbit.empty()) {
        const std::vector<double> bandwidths =
            a.bandwidthsMbit.empty() ? std::vector<double>{1000.0} : a.bandwidthsMbit;
        std::vector<double> rtts = a.rttsMs;
        if (rtts.empty())
            for (const LinkSetting& l : c.links)
                if (std::find(rtts.begin(), rtts.end(), l.rttMs) == rtts.end())
                    rtts.push_back(l.rttMs);
        c.links.clear();
        for (double rtt : rtts) c.links.push_back({rtt, bandwidths.front()});
        for (size_t i = 1; i < bandwidths.size(); ++i) c.links.push_back({100.0, bandwidths[i]});
    }
    if (!a.size.empty()) {
        auto size = parseSize(a.size);
        if (!size) return size.status();
        c.width = size->x;
        c.height = size->y;
    }
    if (a.durationS != 0.0) c.durationS = a.durationS;
    auto layout = warp::parseReferenceLayout(a.refs);
    if (!layout) return layout.status();
    c.layout = *layout;
    c.threads = a.threads;
    PLX_RETURN_IF_ERROR(checkRemoteExperimentConfig(c));
    return c;
}

void printTable(const RemoteExperiment& e, const std::string& dir) {
    fmt::print("{:<10} {:>6} {:>7} {:<9} {:>7} {:>8} {:>7} {:>9} {:>8} {:>8}\n", "scene", "RTT",
               "Mbit/s", "method", "fps", "warp ms", "sets/s", "KiB/set", "age ms", "PSNR dB");
    for (const RemoteRow& r : e.rows)
        fmt::print(
            "{:<10} {:>6g} {:>7g} {:<9} {:>7.1f} {:>8.2f} {:>7.1f} {:>9.1f} {:>8.0f} "
            "{:>8.2f}\n",
            r.scene, r.rttMs, r.bandwidthMbit, remoteMethodName(r.method), r.clientFps,
            r.warpMsMedian, r.referencesPerS, r.bytesPerReference / 1024.0, r.referenceAgeMsMedian,
            r.psnrDbMedian);
    for (const std::string& s : e.config.scenes)
        if (double gain = psnrGainOverVideo(e, s, 100.0); !std::isnan(gain))
            fmt::print("{}: warp {:+.1f} dB over plain video at RTT 100 ms (target +6 dB)\n", s,
                       gain);
    for (const std::string& note : e.notes) fmt::print("note: {}\n", note);
    fmt::print(
        "medians over {:g} s of 60 Hz frames per setting; wrote {}remote.csv, remote.json "
        "and SVG plots\n",
        e.config.durationS, dir);
}

int runRemoteBench(const RemoteBenchArgs& a) {
    auto config = configFrom(a);
    if (!config) return fail(config.status().message(), kExitUsage);
    auto bytes = remoteExperimentBytes(*config);
    if (!bytes) return fail(bytes.status().message(), kExitUsage);
    auto memory = startExperiment("bench remote", config->width, config->height, *bytes, a.out);
    if (!memory) return fail(memory.status());
    StepProgress progress("bench remote");
    auto e = runRemoteExperiment(*config, progress.callback());
    if (!e) return fail(e.status());
    auto files = remotePlots(*e);
    files.emplace_back("remote.csv", remoteCsv(*e));
    nlohmann::json doc = remoteExperimentJson(*e);
    doc.update(memoryJson(*memory));
    return finishExperiment(a.out, a.json, doc, "remote.json", std::move(files),
                            [&](const std::string& dir) { printTable(*e, dir); });
}

}  // namespace

Command addBenchRemote(CLI::App* bench) {
    auto a = std::make_shared<RemoteBenchArgs>();
    CLI::App* sub = bench->add_subcommand(
        "remote", "Mark, Bishop, McMillan: warp vs plain video vs timewarp over real sockets");
    sub->footer(
        "Example: parallax bench remote --quick --json\n         parallax bench remote "
        "--scenes office:8 --rtts 0,100,500 --bandwidths 1000,10 --size 320x240\n"
        "Server and client run in this process over loopback (127.0.0.1), sharing its cores; "
        "the server's link emulation adds the RTT (half each way) and the bandwidth. Default: "
        "office:8 and museum:4, RTT 0,50,100,200,500 ms at 1000 Mbit/s and 100, 10 Mbit/s at "
        "RTT 100, 320x240, 1 s lead-in + 3 s measured per setting (about 1.5 minutes).");
    sub->add_option("--scenes", a->scenes, "Walkthrough scenes (default office:8,museum:4)")
        ->delimiter(',');
    sub->add_option("--rtts", a->rttsMs, "Round-trip times in ms, at the first bandwidth")
        ->delimiter(',');
    sub->add_option("--bandwidths", a->bandwidthsMbit,
                    "Link rates in Mbit/s: the first for the RTT sweep, the others at RTT 100")
        ->delimiter(',');
    sub->add_option("--size", a->size, "Display size WxH (default 320x240)");
    sub->add_option("--duration", a->durationS, "Measured seconds per setting (default 3)");
    sub->add_option("--refs", a->refs, "cube4 | cube6 | wide")->capture_default_str();
    sub->add_option("--threads", a->threads, "Render and warp threads (0: all cores)")
        ->check(CLI::Range(0, 1024));
    sub->add_flag("--quick", a->quick, "One small scene, RTT 0 and 100, 96x72 (for tests)");
    sub->add_option("--out", a->out, "Output folder")
        ->capture_default_str()
        ->check(outputPath(OutputKind::kFolder));
    sub->add_flag("--json", a->json, "Print the rows as JSON");
    return {sub, [a] { return runRemoteBench(*a); }};
}

}  // namespace plx::cli
