// The demo's remote section (Mark, Bishop, McMillan, "The Remote Rendering System"): a short
// real session, server and client in this process over loopback with the round trip emulated on
// the server's socket; one display frame at RTT 100 ms as the warping client, plain video
// streaming and rotation-only timewarp showed it, beside the render at its pose; the PSNR-
// against-RTT plot (experiment_remote.h, `parallax bench remote` at demo size).

#include <fmt/format.h>

#include "bench.h"
#include "cli.h"
#include "demo.h"
#include "experiment_remote.h"

namespace plx::cli {

namespace {

constexpr double kExampleRttMs = 100.0;

RemoteExperimentConfig demoConfig(const DemoContext& ctx) {
    RemoteExperimentConfig c;
    c.scenes = {"office:8"};
    c.threads = ctx.threads;
    c.links = ctx.quick ? std::vector<LinkSetting>{{0, 1000}, {100, 1000}}
                        : std::vector<LinkSetting>{{0, 1000}, {100, 1000}, {300, 1000}};
    c.width = ctx.quick ? 96 : 240;
    c.height = ctx.quick ? 72 : 180;
    c.leadInS = ctx.quick ? 0.5 : 1.0;
    c.durationS = ctx.quick ? 0.5 : 1.5;
    c.exampleRttMs = kExampleRttMs;
    return c;
}

}  // namespace

Status demoRemoteSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    const RemoteExperimentConfig config = demoConfig(ctx);
    StepProgress progress("demo: remote sessions");
    auto e = runRemoteExperiment(config, progress.callback());
    if (!e) return e.status();

    rep.heading("Remote rendering over real sockets (Mark, Bishop, McMillan)");
    rep.paragraph(fmt::format(
        "A render server and a warping client in this process, talking WebSocket over "
        "loopback; the server's link emulation adds the round trip (half each way). The client "
        "plays the {} walkthrough at 60 Hz and warps the newest reference set every frame; "
        "plain video streaming shows the newest received frame as is, rotation-only timewarp "
        "turns it to the current view direction. {}x{}, {:g} s measured per round trip, server "
        "and client sharing this machine's cores.",
        config.scenes.front(), config.width, config.height, config.durationS));

    const std::string dir = ctx.outDir + "/";
    if (e->example) {
        const RemoteExample& x = *e->example;
        PLX_RETURN_IF_ERROR(writePng(dir + "remote_truth.png", x.truth));
        std::vector<std::pair<std::string, std::string>> row = {
            {"remote_truth.png", "render at the current pose"}};
        for (const RemoteExample::Shown& s : x.images) {
            std::string file = fmt::format("remote_{}.png", remoteMethodName(s.method));
            PLX_RETURN_IF_ERROR(writePng(dir + file, s.image));
            row.emplace_back(file, fmt::format("{} at RTT {:g} ms: {:.1f} dB",
                                               remoteMethodName(s.method), x.rttMs, s.psnrDb));
        }
        rep.images(row);
    }
    std::string plots;
    for (const auto& [file, svg] : remotePlots(*e)) {
        PLX_RETURN_IF_ERROR(writeText(dir + "remote_" + file, svg));
        if (file.rfind("psnr_vs_rtt_", 0) == 0 || file.rfind("fps_vs_rtt_", 0) == 0) plots += svg;
    }
    rep.raw("<div class='row'>" + plots + "</div>");
    std::vector<std::vector<std::string>> table;
    for (const RemoteRow& r : e->rows)
        table.push_back({remoteMethodName(r.method), fmt::format("{:g}", r.rttMs),
                         fmt::format("{:.1f}", r.clientFps),
                         fmt::format("{:.1f}", r.referencesPerS),
                         fmt::format("{:.1f}", r.bytesPerReference / 1024.0),
                         fmt::format("{:.1f}", r.psnrDbMedian)});
    rep.table({"method", "RTT ms", "client frames/s", "sets/s", "KiB per set (frame)",
               "PSNR dB (median)"},
              table);
    nlohmann::json summary = remoteExperimentJson(*e);
    summary["warp_gain_over_video_db_at_rtt100"] =
        psnrGainOverVideo(*e, config.scenes.front(), kExampleRttMs);
    (*ctx.summary)["remote"] = summary;
    return Status::ok();
}

}  // namespace plx::cli
