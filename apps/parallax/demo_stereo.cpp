// The demo's stereo section: Heo, Jung, Wohn's experiment (Table 1, Fig. 17) on office:N, the
// pair as an anaglyph and side by side, and the second eye's difference from the full method;
// then the reproject method of Fu, Bao, Peng: a reprojected pair, its hole classes, and the
// second eye of the three methods against the polygon count.

#include <cmath>

#include <fmt/format.h>

#include <plx/scene/generators.h>
#include <plx/stereo/layout.h>

#include "cli.h"
#include "demo.h"
#include "experiment_stereo.h"
#include "hole_classes.h"
#include "view.h"

namespace plx::cli {
namespace {

// Beyond the paper: a pair at a separation of 1, where geometry outside the first eye's view
// (unseen.h) and surfaces spread apart (reproject.h, gaps) would otherwise show what lies behind
// them; its hole classes and its second eye against the full render's.
Status wideSeparationPart(DemoContext& ctx, const scene::Scene& scene, const Camera& center,
                          const StereoRig& rig, stereo::StereoRenderer& renderer) {
    StereoRigDesc desc = rig.desc();
    desc.separation = 1.0f;
    auto wide = StereoRig::create(center, desc);
    if (!wide) return wide.status();
    stereo::StereoOptions options;
    options.method = stereo::Method::kReproject;
    stereo::StereoFrame frame;
    const stereo::StereoFrameStats st = renderer.renderPair(scene, *wide, options, &frame);
    raster::FrameBuffers full;
    renderFullSecondEye(renderer, scene, *wide, options.render, &full);
    const Eye second = wide->secondEye();
    const stereo::SecondEyeQuality q =
        stereo::compareSecondEye(frame.eye(second), full, trianglesShown(frame.eye(second).id));
    PLX_RETURN_IF_ERROR(writePng(ctx.outDir + "/reproject_wide_holes.png",
                                 holeClassImage(frame.eye(second).color, frame.holeClass)));
    ctx.report->paragraph(fmt::format(
        "Beyond the paper, at a separation of 1 (15 times the default): the second eye against "
        "the full render gives {:.1f} dB PSNR, {:.2f}% of its pixels identical. Geometry outside "
        "the first eye's view is drawn where it is nearest ({} pixels; those it hid after they had "
        "landed magenta), and a "
        "pixel landing between two neighbours of a surface the second eye sees spread apart, "
        "behind them, becomes a hole the fill draws (docs/stereo-results.md measures both).",
        q.psnrDb, 100.0 * (1.0 - q.differingFraction), st.unseenPixels));
    ctx.report->images({{"reproject_wide_holes.png", "separation 1: second eye, hole classes"}});
    return Status::ok();
}

// The reproject method's part: one pair of the largest scene, its hole classes, the wide pair
// above, and the table of the three methods (the plot of their second eyes is among stereoPlots).
Status reprojectPart(DemoContext& ctx, const std::vector<StereoExperimentRow>& rows,
                     const scene::Scene& scene, const Camera& center, const StereoRig& rig,
                     stereo::StereoRenderer& renderer) {
    HtmlReport& rep = *ctx.report;
    PLX_RETURN_IF_ERROR(renderer.prepareReprojection(scene));
    stereo::StereoOptions options;
    options.method = stereo::Method::kReproject;
    stereo::StereoFrame frame;
    stereo::StereoFrameStats st = renderer.renderPair(scene, rig, options, &frame);
    std::string dir = ctx.outDir + "/";
    PLX_RETURN_IF_ERROR(writePng(
        dir + "reproject_sbs.png",
        stereo::composeStereo(frame.left.color, frame.right.color, stereo::Layout::kSideBySide)));
    std::vector<std::pair<std::string, std::string>> images = {
        {"reproject_sbs.png", "side by side: left | right (reproject method)"}};
    if (!frame.holeClass.empty()) {
        PLX_RETURN_IF_ERROR(
            writePng(dir + "reproject_holes.png",
                     holeClassImage(frame.eye(rig.secondEye()).color, frame.holeClass)));
        images.emplace_back("reproject_holes.png", "second eye: hole classes");
    }
    rep.heading("Stereo by reprojection (Fu, Bao, Peng)", 3);
    rep.paragraph(fmt::format(
        "The second eye is made by moving each first-eye pixel by its disparity; the pixels no "
        "first-eye pixel lands on form holes, classified by the polygon IDs around them and "
        "filled by drawing only the polygons behind each hole. In the pair below, {} of {} "
        "second-eye pixels were holes ({} expansion and {} disocclusion holes, {} polygon "
        "fragments drawn). Hole classes: {}.",
        st.holePixels, frame.right.color.pixelCount(), st.expansionHoles, st.disocclusionHoles,
        st.fillPolygonsDrawn, kHoleClassLegend));
    rep.images(images);
    PLX_RETURN_IF_ERROR(wideSeparationPart(ctx, scene, center, rig, renderer));
    std::vector<std::vector<std::string>> table;
    for (const auto& r : rows)
        table.push_back(
            {fmt::format("{}", r.polygons), fmt::format("{:.2f}", r.fullSecondMs),
             fmt::format("{:.2f}", r.pbufferSecondMs + r.collectMs),
             fmt::format("{:.2f}", r.reprojectSecondMs),
             fmt::format("{:.2f}x", r.reprojectPairSpeedup),
             fmt::format("{:.1f}", std::isfinite(r.reprojectPsnrDb) ? r.reprojectPsnrDb : 99.0),
             fmt::format("{:.4f}", r.reprojectIdenticalFraction),
             fmt::format("{:.4f}", r.reprojectHoleFraction)});
    rep.table({"polygons", "full 2nd ms", "p-buf 2nd ms", "reproject 2nd ms",
               "reproject pair speedup", "reproject PSNR dB", "identical", "holes"},
              table);
    return Status::ok();
}

}  // namespace

Status demoStereoSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    StereoExperimentConfig config;
    if (ctx.quick) {
        config.rooms = {1, 4};
        config.width = 160;
        config.height = 120;
        config.frames = 1;
    } else {
        config.frames = 3;
    }
    config.threads = ctx.threads;
    Progress progress("demo: stereo experiment", config.rooms.size());
    auto rows = runStereoExperiment(config, [&](size_t, size_t) { progress.step(); });
    if (!rows) return rows.status();

    rep.heading("Stereo from the P-buffer (Heo, Jung, Wohn)");
    rep.paragraph(fmt::format(
        "The first eye is rendered with the P-buffer; the second eye is drawn from the polygons "
        "whose IDs appear in it. office:N from {} to {} rooms ({} to {} polygons) at {}x{}, "
        "eye separation {} m, convergence {} m. The second eye's cost follows the visible "
        "polygons, not the scene.",
        rows->front().rooms, rows->back().rooms, rows->front().polygons, rows->back().polygons,
        config.width, config.height, config.rig.separation, config.rig.convergence));

    // One pair of the largest scene, shown three ways.
    auto scene = scene::generateOffice(rows->back().rooms);
    if (!scene) return scene.status();
    auto center = scene::cameraAt(*scene, scene->viewpoints.front(), config.width, config.height);
    if (!center) return center.status();
    auto rig = StereoRig::create(*center, config.rig);
    if (!rig) return rig.status();
    auto renderer = stereo::StereoRenderer::create({ctx.threads});
    if (!renderer) return renderer.status();
    stereo::StereoFrame pbuf, full;
    (*renderer)->renderPair(*scene, *rig, {}, &pbuf);
    stereo::StereoOptions fullOptions;
    fullOptions.method = stereo::Method::kFull;
    (*renderer)->renderPair(*scene, *rig, fullOptions, &full);
    std::string dir = ctx.outDir + "/";
    Eye second = rig->secondEye();
    PLX_RETURN_IF_ERROR(writePng(
        dir + "stereo_anaglyph.png",
        stereo::composeStereo(pbuf.left.color, pbuf.right.color, stereo::Layout::kAnaglyph)));
    PLX_RETURN_IF_ERROR(writePng(
        dir + "stereo_sbs.png",
        stereo::composeStereo(pbuf.left.color, pbuf.right.color, stereo::Layout::kSideBySide)));
    PLX_RETURN_IF_ERROR(
        writePng(dir + "stereo_diff.png",
                 diffImage(pbuf.eye(second).color, full.eye(second).color, 4.0f, 40)));
    rep.images({{"stereo_anaglyph.png", "red-cyan anaglyph (p-buffer method)"},
                {"stereo_sbs.png", "side by side: left | right"},
                {"stereo_diff.png", "second eye: p-buffer vs full (x4, magenta > 40)"}});

    std::string plots, methodsPlot;
    for (const auto& [file, svg] : stereoPlots(*rows)) {
        PLX_RETURN_IF_ERROR(writeText(dir + "stereo_" + file, svg));
        (file == "second_eye_methods.svg" ? methodsPlot : plots) += svg;
    }
    rep.raw("<div class='row'>" + plots + "</div>");
    std::vector<std::vector<std::string>> table;
    for (const auto& r : *rows)
        table.push_back(
            {fmt::format("{}", r.rooms), fmt::format("{}", r.polygons),
             fmt::format("{}", r.visiblePolygons), fmt::format("{:.2f}", r.fullFirstMs),
             fmt::format("{:.2f}", r.fullSecondMs), fmt::format("{:.2f}", r.pbufferFirstMs),
             fmt::format("{:.2f}", r.pbufferSecondMs + r.collectMs),
             fmt::format("{:.2f}x", r.pairSpeedup),
             fmt::format("{:.1f}", std::isfinite(r.secondEyePsnrDb) ? r.secondEyePsnrDb : 99.0),
             fmt::format("{}", r.missedPolygons), fmt::format("{}", r.conservativeMissedPolygons)});
    rep.table({"rooms", "polygons", "visible", "full 1st ms", "full 2nd ms", "p-buf 1st ms",
               "p-buf 2nd ms", "pair speedup", "2nd-eye PSNR dB", "missed polygons",
               "missed (conservative)"},
              table);
    PLX_RETURN_IF_ERROR(reprojectPart(ctx, *rows, *scene, *center, *rig, **renderer));
    rep.raw("<div class='row'>" + methodsPlot + "</div>");
    (*ctx.summary)["stereo"] = stereoExperimentJson(config, *rows);
    return Status::ok();
}

}  // namespace plx::cli
