// The demo's texture-streaming section (Marvie & Bouatouch sections 5-7): the stream experiment
// (experiment_stream.h) on museum:4: the tour through every room at four bandwidths, the
// progressive downloading quality over time (the paper's Fig. 2), the resident bytes against the
// budget, frame time against a full-resolution baseline, frames at Fig. 3's moments at 56 kbit/s,
// and the ACH allocation against LRU and an equal split by texture PSNR.

#include <fmt/format.h>

#include <plx/core/image_io.h>

#include "cli.h"
#include "demo.h"
#include "experiment_stream.h"

namespace plx::cli {

Status demoStreamSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    StreamExperimentConfig config;
    config.scene = "museum:4";
    config.dbDir = ctx.outDir + "/stream_db";
    config.threads = ctx.threads;
    config.width = ctx.quick ? 80 : 320, config.height = ctx.quick ? 60 : 240;
    config.tour.stopS = ctx.quick ? 1.0 : 15.0;
    config.policyBudgets = {uint64_t(256) << 10, uint64_t(512) << 10};
    config.psnrEvery = ctx.quick ? 30 : 15;
    if (ctx.quick) config.sampling.samples = 2, config.sampling.faceSize = 32;
    Progress progress("demo: texture streaming", 1);
    auto e = runStreamExperiment(config);
    if (!e) return e.status();
    progress.step();

    rep.heading("Texture streaming under a memory budget (Marvie, Bouatouch)");
    rep.paragraph(fmt::format(
        "{} split into {} cells (its rooms); each cell's potentially visible set and average "
        "coverage hints come from {} sample points with six 90-degree ID renders each. The "
        "database ({:.1f} MB: {} PTM textures, one glTF binary per cell) is walked through every "
        "room ({:.0f} s at 30 fps, {:g} s still in each room) over a simulated link with 50 ms "
        "latency per request; the client splits a {} MiB budget (moving) or {} MiB (static) by the "
        "hints and keeps only the PTM levels that fit. Quality is the paper's progressive "
        "downloading quality: downloaded levels over the levels of the textures in view. The "
        "frame time compares the streamed walk (unlimited link) with a baseline that draws the "
        "whole museum with every texture at full resolution.",
        config.scene, e->cells, config.sampling.samples, double(e->databaseBytes) / 1e6,
        e->textures, double(e->tourFrames) / config.tour.fps, config.tour.stopS,
        config.budgetBytes >> 20, config.staticBudgetBytes >> 20));
    std::string plots;
    for (const auto& [file, svg] : streamPlots(*e)) {
        PLX_RETURN_IF_ERROR(writeText(ctx.outDir + "/" + file, svg));
        plots += svg;
    }
    rep.raw("<div class='row'>" + plots + "</div>");
    std::vector<std::pair<std::string, std::string>> shots;
    for (const BandwidthRun& run : e->runs)
        for (const auto& [timeS, image] : run.shots) {
            const std::string file = fmt::format("stream_{:02}s.png", int(timeS));
            PLX_RETURN_IF_ERROR(writePng(ctx.outDir + "/" + file, image));
            const size_t frame = size_t(timeS * config.tour.fps);
            const double quality = frame < run.frames.size() ? run.frames[frame].quality : 0.0;
            shots.emplace_back(file, fmt::format("{} at {:g} s: quality {:.0f}%",
                                                 bandwidthName(run.kbit), timeS, 100.0 * quality));
        }
    if (!e->fullShot.empty()) {
        PLX_RETURN_IF_ERROR(writePng(ctx.outDir + "/stream_full.png", e->fullShot));
        shots.emplace_back("stream_full.png", "every texture at full resolution");
    }
    if (!shots.empty()) rep.images(shots);

    std::vector<std::vector<std::string>> table;
    for (const BandwidthRun& r : e->runs)
        table.push_back({bandwidthName(r.kbit), fmt::format("{:.1f}", 100.0 * r.qualityFinal),
                         r.firstAt90S < 0.0 ? "never" : fmt::format("{:.1f}", r.firstAt90S),
                         fmt::format("{} / {}", r.maxResidentBytes, r.maxBudgetBytes),
                         fmt::format("{:.2f}", double(r.downloadedBytes) / 1e6),
                         std::to_string(r.failedRequests)});
    rep.table({"link", "final quality %", "first >= 90% at s", "max resident / budget bytes",
               "downloaded MB", "failed requests"},
              table);
    std::vector<std::vector<std::string>> policies;
    for (const PolicyRow& p : e->policies)
        policies.push_back({std::string(stream::policyName(p.policy)),
                            fmt::format("{:.2f}", double(p.budgetBytes) / double(1 << 20)),
                            fmt::format("{:.2f}", p.psnrDb),
                            fmt::format("{:.2f}", p.psnrAfterFirstStopDb),
                            std::to_string(p.framesCompared),
                            fmt::format("{} / {}", p.maxResidentBytes, p.budgetBytes)});
    rep.table({"policy", "budget MiB", "texture PSNR dB", "after the first stop dB",
               "frames compared",
               "max resident / budget bytes"},
              policies);
    (*ctx.summary)["stream"] = streamExperimentJson(*e);
    return Status::ok();
}

}  // namespace plx::cli
