// parallax render SCENE: renders colour, depth and polygon-ID targets with the software
// rasterizer and reports timings.

#include <fmt/format.h>

#include <plx/raster/raster.h>
#include <plx/scene/import.h>

#include "commands.h"
#include "view.h"

namespace plx::cli {

namespace {

// Peak bytes per image pixel beyond the scene (checkImageMemory): the colour, depth and ID
// targets and the PNGs' images. The growth of the peak from 1024x1024 to 2048x2048 (office:2)
// is 20.3; MemoryCli.EstimatesHoldTheMeasuredPeak holds it to the measured peak.
constexpr double kRenderBytesPerPixel = 22.0;

struct RenderArgs {
    std::string scene;
    ViewArgs view;
    std::string shading = "flat";
    int frames = 1;
    int threads = 0;
    bool cull = false;
    std::string out;
    bool json = false;
};

int runRender(const RenderArgs& a) {
    if (a.frames < 1 || a.frames > 100000)
        return fail(fmt::format("--frames {} outside 1 .. 100000", a.frames), kExitUsage);
    auto shading = raster::parseShading(a.shading);
    if (!shading) return fail(shading.status().message(), kExitUsage);
    auto renderer = raster::Renderer::create({a.threads});
    if (!renderer) return fail(renderer.status().message(), kExitUsage);
    if (auto size = parseSize(a.view.size); !size) return fail(size.status().message(), kExitUsage);
    auto scene = loadSceneChecked(a.scene);
    if (!scene) return fail(scene.status());
    auto camera = cameraFor(*scene, a.view);
    if (!camera) return fail(camera.status().message(), kExitUsage);
    if (Status s = ensureParentDirectory(a.out); !s) return fail(s);
    const double pixels = double(camera->width()) * double(camera->height());
    auto memory =
        checkImageMemory(fmt::format("render at {}x{}", camera->width(), camera->height()),
                         kRenderBytesPerPixel * pixels, scene->triangleCount());
    if (!memory) return fail(memory.status());

    raster::RenderOptions options;
    options.shading = *shading;
    options.cullBackFaces = a.cull;
    raster::FrameBuffers fb;
    fb.resize(camera->width(), camera->height());
    std::vector<double> ms;
    raster::RenderStats last;
    Progress progress("rendering", size_t(a.frames));
    for (int f = 0; f < a.frames; ++f) {
        last = (*renderer)->render(*scene, *camera, options, fb.targets());
        ms.push_back(last.milliseconds);
        progress.step();
    }
    double medianMs = median(ms);
    size_t visible = raster::countDistinctIds(fb.id);
    std::string colorPath = a.out + ".color.png", depthPath = a.out + ".depth.png",
                idPath = a.out + ".id.png";
    if (Status s = writePng(colorPath, fb.color); !s) return fail(s);
    if (Status s = writePng(depthPath, raster::visualizeDepth(fb.depth)); !s) return fail(s);
    if (Status s = writePng(idPath, raster::visualizeIds(fb.id)); !s) return fail(s);

    double mtris = medianMs > 0 ? double(scene->triangleCount()) / (medianMs * 1e3) : 0.0;
    if (a.json) {
        nlohmann::json doc = {{"scene", a.scene},
                              {"triangles", scene->triangleCount()},
                              {"visible_triangles", visible},
                              {"width", camera->width()},
                              {"height", camera->height()},
                              {"frames", a.frames},
                              {"shading", raster::shadingName(*shading)},
                              {"threads", (*renderer)->threadCount()},
                              {"frame_ms_median", medianMs},
                              {"mtris_per_s", mtris},
                              {"triangles_clipped", last.trianglesClipped},
                              {"triangles_binned", last.trianglesBinned},
                              {"tile_pairs_occluded", last.tilePairsOccluded},
                              {"outputs", {colorPath, depthPath, idPath}}};
        doc.update(memoryJson(*memory));
        printJson(doc);
    } else {
        fmt::print("{}: {} triangles, {} visible, {}x{}, {} shading, {}\n", a.scene,
                   scene->triangleCount(), visible, camera->width(), camera->height(),
                   raster::shadingName(*shading),
                   counted(uint64_t((*renderer)->threadCount()), "thread"));
        fmt::print("median {:.2f} ms/frame over {} ({:.1f} Mtri/s)\n", medianMs,
                   counted(uint64_t(a.frames), "frame"), mtris);
        fmt::print("wrote {}, {}, {}\n", colorPath, depthPath, idPath);
    }
    return kExitOk;
}

}  // namespace

Command registerRender(CLI::App& app) {
    auto a = std::make_shared<RenderArgs>();
    CLI::App* sub = app.add_subcommand("render", "Render colour, depth and polygon-ID images");
    sub->footer("Example: parallax render office:16 --size 1280x720 --frames 10 --out out/office "
                "--json");
    sub->add_option("scene", a->scene, "Model file or generator spec (office:N, museum:N)")
        ->required();
    addViewOptions(sub, &a->view);
    sub->add_option("--shading", a->shading, "flat | gouraud | textured")->capture_default_str();
    sub->add_option("--frames", a->frames, "Frames to render (timings use the median)")
        ->capture_default_str();
    sub->add_option("--threads", a->threads, "Worker threads (0: all cores)")->capture_default_str();
    sub->add_flag("--cull", a->cull, "Cull back faces (counter-clockwise fronts)");
    sub->add_option("--out", a->out, "Output prefix: PREFIX.color.png, .depth.png, .id.png")
        ->required()
        ->check(outputPath(OutputKind::kPrefix));
    sub->add_flag("--json", a->json, "Print a JSON result on stdout");
    return {sub, [a] { return runRender(*a); }};
}

}  // namespace plx::cli
