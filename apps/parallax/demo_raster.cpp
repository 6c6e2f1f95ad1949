// The demo's rasterizer section: office:1 .. office:16 (the P-buffer paper's scene sizes), and
// the shared DamagedHelmet model when present.

#include <filesystem>

#include <fmt/format.h>

#include <plx/raster/raster.h>
#include <plx/scene/generators.h>
#include <plx/scene/import.h>

#include "demo.h"
#include "view.h"

namespace plx::cli {
namespace {

struct SceneRun {
    size_t triangles = 0, visible = 0;
    double ms = 0.0;
};

// Renders `frames` frames and writes colour, depth and ID images under ctx.outDir/name.*.png
// when name is non-empty.
Result<SceneRun> renderScene(const scene::Scene& scene, const Camera& camera,
                             raster::Renderer& renderer, raster::Shading shading, int frames,
                             const DemoContext& ctx, const std::string& name) {
    raster::FrameBuffers fb;
    fb.resize(camera.width(), camera.height());
    raster::RenderOptions options;
    options.shading = shading;
    std::vector<double> ms;
    for (int f = 0; f < frames; ++f) ms.push_back(renderer.render(scene, camera, options, fb.targets()).milliseconds);
    SceneRun run{scene.triangleCount(), raster::countDistinctIds(fb.id), median(ms)};
    if (!name.empty()) {
        std::string base = ctx.outDir + "/" + name;
        PLX_RETURN_IF_ERROR(writePng(base + ".color.png", fb.color));
        PLX_RETURN_IF_ERROR(writePng(base + ".depth.png", raster::visualizeDepth(fb.depth)));
        PLX_RETURN_IF_ERROR(writePng(base + ".id.png", raster::visualizeIds(fb.id)));
    }
    return run;
}

}  // namespace

Status demoRasterSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    const int width = ctx.quick ? 320 : 960, height = ctx.quick ? 180 : 540;
    const int frames = ctx.quick ? 1 : 5;
    const int maxRooms = ctx.quick ? 4 : 16;
    auto renderer = raster::Renderer::create({ctx.threads});
    if (!renderer) return renderer.status();

    rep.heading("Foundation: the P-buffer rasterizer");
    rep.paragraph(fmt::format(
        "The office scene of Heo, Jung and Wohn (Table 1), replicated 1 to {} times, rendered at "
        "{}x{} with flat shading by the tiled software rasterizer. Each frame writes colour, "
        "depth (1/z) and the P-buffer: the polygon ID of the visible triangle at every pixel. "
        "Visible polygons level off as rooms are added, as in the paper.",
        maxRooms, width, height));

    std::vector<std::vector<std::string>> rows;
    PlotSeries timeSeries{"frame time (ms)", {}}, visibleSeries{"visible triangles", {}};
    nlohmann::json runs = nlohmann::json::array();
    Progress progress("demo: office scenes", size_t(maxRooms));
    for (int n = 1; n <= maxRooms; ++n) {
        auto scene = scene::generateFromSpec(fmt::format("office:{}", n));
        if (!scene) return scene.status();
        auto cam = scene::cameraAt(*scene, scene->viewpoints.front(), width, height);
        if (!cam) return cam.status();
        bool keep = n == 1 || n == 4 || n == maxRooms;
        auto run = renderScene(*scene, *cam, **renderer, raster::Shading::kFlat, frames, ctx,
                               keep ? fmt::format("office{}", n) : "");
        if (!run) return run.status();
        rows.push_back({fmt::format("{}", n), fmt::format("{}", run->triangles),
                        fmt::format("{}", run->visible), fmt::format("{:.2f}", run->ms),
                        fmt::format("{:.1f}", double(run->triangles) / (run->ms * 1e3))});
        timeSeries.points.emplace_back(double(run->triangles), run->ms);
        visibleSeries.points.emplace_back(double(run->triangles), double(run->visible));
        runs.push_back({{"rooms", n}, {"triangles", run->triangles},
                        {"visible_triangles", run->visible}, {"frame_ms", run->ms}});
        progress.step();
    }
    for (int n : {1, 4, maxRooms})
        rep.images({{fmt::format("office{}.color.png", n), fmt::format("office:{} colour", n)},
                    {fmt::format("office{}.depth.png", n), fmt::format("office:{} depth", n)},
                    {fmt::format("office{}.id.png", n), fmt::format("office:{} polygon IDs", n)}});
    rep.raw("<div class='row'>" +
            svgLinePlot({"Frame time against scene size", "triangles", "ms per frame"},
                        {timeSeries}) +
            svgLinePlot({"Visible triangles (distinct P-buffer IDs)", "triangles",
                         "visible triangles"},
                        {visibleSeries}) +
            "</div>");
    rep.table({"rooms", "triangles", "visible", "ms/frame (median)", "Mtri/s"}, rows);
    (*ctx.summary)["raster"] = {{"width", width}, {"height", height}, {"runs", runs}};

    std::string helmet = std::string(PLX_SHARED_DATA_DIR) + "/models/DamagedHelmet/DamagedHelmet.glb";
    if (!ctx.quick && std::filesystem::exists(helmet)) {
        auto scene = loadSceneChecked(helmet);
        if (!scene) return scene.status();
        auto cam = scene::cameraAt(*scene, scene::defaultViewpoint(*scene), width, height);
        if (!cam) return cam.status();
        auto run = renderScene(*scene, *cam, **renderer, raster::Shading::kTextured, frames, ctx,
                               "helmet");
        if (!run) return run.status();
        rep.heading("A real model: DamagedHelmet (textured)", 3);
        rep.paragraph(fmt::format("{} triangles, {} visible, {:.2f} ms per frame, bilinear "
                                  "mipmapped texturing with Gouraud lighting.",
                                  run->triangles, run->visible, run->ms));
        rep.images({{"helmet.color.png", "colour"}, {"helmet.depth.png", "depth"},
                    {"helmet.id.png", "polygon IDs"}});
        (*ctx.summary)["helmet"] = {{"triangles", run->triangles},
                                    {"visible_triangles", run->visible},
                                    {"frame_ms", run->ms}};
    }
    return Status::ok();
}

}  // namespace plx::cli
