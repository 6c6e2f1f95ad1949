// The demo's warp section (Mark, Bishop, McMillan): one display frame of a walkthrough seen
// through a 100 ms round trip, stale, timewarped and warped, next to the render at the current
// pose; and the PSNR-against-RTT plot of the latency experiment.

#include <fmt/format.h>

#include "cli.h"
#include "demo.h"
#include "experiment_warp.h"

namespace plx::cli {

namespace {

WarpExperimentConfig demoConfig(const DemoContext& ctx) {
    WarpExperimentConfig c;
    c.scenes = {"office:8"};
    c.threads = ctx.threads;
    c.rttsMs = ctx.quick ? std::vector<double>{0, 100, 300}
                         : std::vector<double>{0, 50, 100, 200, 300, 500};
    c.durationS = ctx.quick ? 0.05 : 0.5;
    c.width = ctx.quick ? 96 : 240;
    c.height = ctx.quick ? 72 : 180;
    // The throughput table belongs to `parallax bench warp`.
    c.throughputSizes.clear();
    c.sizeScenes.clear();
    return c;
}

}  // namespace

Status demoWarpSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    WarpExperimentConfig config = demoConfig(ctx);
    const double exampleRtt = 100.0;
    auto example = latencyExample(config.scenes.front(), config, exampleRtt, ctx.quick ? 0 : 20);
    if (!example) return example.status();
    Progress progress("demo: warp latency experiment", 1);
    auto e = runWarpExperiment(config);
    if (!e) return e.status();
    progress.step();

    rep.heading("Latency compensation by post-rendering warp (Mark, Bishop, McMillan)");
    rep.paragraph(fmt::format(
        "A client on a 60 Hz display asks a distant render server for reference images of its "
        "pose every {:g} ms; each answer arrives one round trip later. Without compensation the "
        "display shows the frame rendered for where the head was (stale); rotation-only "
        "timewarp turns that frame to the current view direction; the warp moves cube-face "
        "references carrying disparity (1/z) to the current pose, so translation is "
        "compensated too. {} walkthrough at {}x{}, medians over {:g} s of frames.",
        config.refreshMs, config.scenes.front(), config.width, config.height, config.durationS));

    const std::string dir = ctx.outDir + "/";
    PLX_RETURN_IF_ERROR(writePng(dir + "warp_truth.png", example->truth));
    std::vector<std::pair<std::string, std::string>> row = {
        {"warp_truth.png", "render at the current pose"}};
    for (const LatencyExample::Shown& s : example->images) {
        if (s.method == LatencyMethod::kWarp1) continue;
        std::string file = fmt::format("warp_{}.png", latencyMethodName(s.method));
        PLX_RETURN_IF_ERROR(writePng(dir + file, s.image));
        row.emplace_back(file, fmt::format("{} at RTT {:g} ms: {:.1f} dB",
                                           latencyMethodName(s.method), exampleRtt, s.psnrDb));
    }
    rep.images(row);

    std::string plots;
    for (const auto& [file, svg] : warpPlots(*e)) {
        PLX_RETURN_IF_ERROR(writeText(dir + "warp_" + file, svg));
        if (file.rfind("psnr_vs_rtt_", 0) == 0) plots += svg;
    }
    rep.raw("<div class='row'>" + plots + "</div>");
    std::vector<std::vector<std::string>> table;
    for (const LatencyRow& r : e->latency)
        table.push_back({latencyMethodName(r.method), fmt::format("{:g}", r.rttMs),
                         fmt::format("{:.1f}", r.psnrDbMedian),
                         fmt::format("{:.3f}", 100.0 * r.holeFractionMedian),
                         figureOrEmpty(r.warpMsMedian, "{:.2f}", "-")});
    rep.table({"method", "RTT ms", "PSNR dB (median)", "holes % (median)", "client ms (median)"},
              table);
    (*ctx.summary)["warp"] = warpExperimentJson(*e);
    return Status::ok();
}

}  // namespace plx::cli
