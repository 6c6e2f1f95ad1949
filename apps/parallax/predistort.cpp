// parallax predistort DISPLAY.json: one predistorted frame for a curved display (Bimber et al.):
// pass 1 renders the scene for the viewer, the adaptive (or uniform) warp mesh is generated and
// validated, pass 2 renders the mesh textured with the pass-1 image. Writes the mesh, an overlay
// of the grid and the predistorted frame.

#include <cmath>
#include <optional>

#include <fmt/format.h>

#include <plx/core/image_io.h>
#include <plx/core/parallel.h>
#include <plx/core/timing.h>
#include <plx/display/display_json.h>
#include <plx/display/mesh_io.h>
#include <plx/display/predistort.h>
#include <plx/display/validate.h>
#include <plx/scene/generators.h>
#include <plx/scene/import.h>

#include "commands.h"
#include "example_displays.h"
#include "experiment_predistort.h"
#include "view.h"

namespace plx::cli {
namespace {

// Lattice divisions per triangle edge when the mesh's error is measured (as in the experiment).
constexpr int kValidationDivisions = 4;
// The Bourke format stores a regular grid: the mesh is resampled at this level (129 x 129 nodes)
// unless the mesh itself is coarser.
constexpr int kBourkeLevel = 7;
// Timings: median of this many frames after one warm-up frame.
constexpr int kRepetitions = 5;

struct PredistortArgs {
    std::string display;
    std::string viewer;
    double errorMm = 1.0;
    std::string scene;
    std::string method = "adaptive";
    // The experiment's (and `bench predistort`'s) default: the coarse hull.
    std::string container = display::containerKindName(PredistortExperimentConfig{}.container);
    std::string out;
    std::string format = "bourke";
    int gridLevel = 9;
    int pass1Size = 512;
    int threads = 0;
    bool json = false;
};

// The scene in display millimetres: the given one (a file or a generator spec) or the built-in
// exhibit (the showcase generator), fitted to the display's content sphere.
Result<scene::Scene> loadContent(const std::string& spec, const display::Display& d) {
    auto s = spec.empty() ? scene::generateShowcase() : loadSceneChecked(spec);
    if (!s) return s.status();
    return display::fitSceneToContent(*s, d);
}

// --viewer as given, checked before any file is read (a usage error); none: the display file's.
Result<std::optional<display::DVec3>> parseViewer(const std::string& text) {
    if (text.empty()) return std::optional<display::DVec3>();
    auto v = parseVec3(text);
    if (!v) return errorStatus(v.status().code(), "--viewer: " + v.status().message());
    if (!std::isfinite(v->x) || !std::isfinite(v->y) || !std::isfinite(v->z))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--viewer '{}' must be three finite numbers", text));
    return std::optional<display::DVec3>(display::DVec3(*v));
}

// Peak bytes per framebuffer pixel beyond the scene and pass 1 (predistortImageBytes): pass 2's
// targets, the frame, its overlay and their PNGs; the growth of the peak from 2048x2048 to
// 4096x4096 framebuffers (cone_showcase) is 20.2, with --format pfm 36.1 (the map's floats and
// its bytes). Rounded up; MemoryCli.EstimatesHoldTheMeasuredPeak holds them to the measured peak.
// The warp mesh comes on top: about 170 bytes a vertex, at most (2^m + 1)^2 vertices at
// --grid-level m (the examples at level 11 and 0.0001 mm: 0.18M to 0.58M vertices, 30-100 MB).
double framebufferBytesPerPixel(const PredistortArgs& a) {
    return a.format == "pfm" ? 37.0 : 21.0;
}

Status writeMesh(const PredistortArgs& a, const display::Display& d,
                 const display::WarpMesh& mesh, std::string* path) {
    if (a.format == "obj") {
        *path = a.out + "_mesh.obj";
        return writeText(*path, display::formatObj(mesh));
    }
    if (a.format == "pfm") {
        *path = a.out + "_warp.pfm";
        return writeFileBytes(*path, display::encodeWarpPfm(d, mesh, d.framebufferWidth,
                                                            d.framebufferHeight));
    }
    *path = a.out + "_mesh.txt";
    int level = std::max(1, std::min(kBourkeLevel, mesh.gridLevel));
    return writeText(*path, display::formatBourke(d, display::resampleToGrid(mesh, level)));
}

int run(const PredistortArgs& a) {
    if (!std::isfinite(a.errorMm) || a.errorMm <= 0.0)
        return fail("--error must be a positive number of millimetres", kExitUsage);
    auto method = a.method;
    if (method != "adaptive" && method != "uniform")
        return fail(fmt::format("--method '{}' is not adaptive or uniform", method), kExitUsage);
    if (a.format != "bourke" && a.format != "obj" && a.format != "pfm")
        return fail(fmt::format("--format '{}' is not bourke, obj or pfm", a.format), kExitUsage);
    auto containerKind = display::parseContainerKind(a.container);
    if (!containerKind) return fail(containerKind.status().message(), kExitUsage);
    auto viewerArg = parseViewer(a.viewer);
    if (!viewerArg) return fail(viewerArg.status().message(), kExitUsage);
    auto d = loadDisplayArgument(a.display);
    if (!d) return fail(d.status());
    const display::DVec3 viewer = viewerArg->value_or(d->defaultViewerMm);
    display::Display viewed = *d;
    viewed.defaultViewerMm = viewer;
    if (Status s = display::validateDisplay(viewed); !s) return fail(s);
    auto content = loadContent(a.scene, *d);
    if (!content) return fail(content.status());
    auto memory =
        checkImageMemory(fmt::format("predistort{} at {}x{} (pass 1 {}x{})",
                                     a.format == "pfm" ? " --format pfm" : "", d->framebufferWidth,
                                     d->framebufferHeight, a.pass1Size, a.pass1Size),
                         predistortImageBytes(*d, a.pass1Size, framebufferBytesPerPixel(a)),
                         content->triangleCount());
    if (!memory) return fail(memory.status());
    if (Status s = ensureParentDirectory(a.out); !s) return fail(s);

    display::ImagePlane plane =
        display::makeImagePlane(viewer, d->contentCenterMm, d->contentRadiusMm);
    auto pass2 = display::PredistortRenderer::create(a.threads);
    if (!pass2) return fail(pass2.status());
    double pass1Ms = 0.0;  // pass 1 straight into the image pass 2 samples
    if (Status s = display::renderViewerImage((*pass2)->renderer(), *content, plane, a.pass1Size,
                                              &(*pass2)->viewerImage(), &pass1Ms);
        !s)
        return fail(s);

    // The warp mesh, timed over a few frames (generation runs on one core).
    display::WarpMesh mesh;
    display::WarpStats stats;
    ThreadPool pool(a.threads);
    std::vector<double> genMs;
    int uniformLevel = -1;
    if (method == "adaptive") {
        auto warper = display::QuadtreeWarper::create({a.gridLevel, a.errorMm});
        if (!warper) return fail(warper.status());
        display::Container container =
            display::makeContainer(*containerKind, display::scenePointsMm(*content));
        for (int r = 0; r <= kRepetitions; ++r) {
            Stopwatch sw;
            (*warper)->generate(*d, plane, &container, &mesh, &stats);
            if (r > 0) genMs.push_back(sw.elapsedMs());
        }
    } else {
        // The coarsest uniform grid whose measured maximum error meets the threshold.
        for (uniformLevel = 1; uniformLevel < 10; ++uniformLevel) {
            display::generateUniform(*d, plane, uniformLevel, &mesh, &stats);
            if (display::measureMeshError(*d, plane, mesh, kValidationDivisions, &pool)
                    .maxErrorMm <= a.errorMm)
                break;
        }
        for (int r = 0; r <= kRepetitions; ++r) {
            Stopwatch sw;
            display::generateUniform(*d, plane, uniformLevel, &mesh, &stats);
            if (r > 0) genMs.push_back(sw.elapsedMs());
        }
    }
    // An empty mesh measures "0.0000 mm" and renders a blank frame: say why instead.
    if (mesh.vertexCount() == 0)
        return fail(
            fmt::format("the viewer at ({:g}, {:g}, {:g}) mm sees none of the display's "
                        "content through its optics: no warp mesh to build",
                        viewer.x, viewer.y, viewer.z));
    display::ErrorMeasurement err =
        display::measureMeshError(*d, plane, mesh, kValidationDivisions, &pool);

    std::vector<double> renderMs;
    const Image<Rgba8>* frame = nullptr;
    for (int r = 0; r <= kRepetitions; ++r) {
        double ms = 0.0;
        auto out = (*pass2)->render(*d, mesh, &ms);
        if (!out) return fail(out.status());
        frame = *out;
        if (r > 0) renderMs.push_back(ms);
    }

    std::string meshPath, framePath = a.out + "_frame.png", overlayPath = a.out + "_overlay.png";
    if (Status s = writeMesh(a, *d, mesh, &meshPath); !s) return fail(s);
    if (Status s = writePng(framePath, *frame); !s) return fail(s);
    Image<Rgba8> overlay = display::drawMeshOverlay(*d, mesh, frame);
    if (Status s = writePng(overlayPath, overlay); !s) return fail(s);

    nlohmann::json doc = {{"method", method},
                          {"error_mm", a.errorMm},
                          {"max_measured_error_mm", err.maxErrorMm},
                          {"vertices", mesh.vertexCount()},
                          {"triangles", mesh.triangleCount()},
                          {"patches", stats.patches},
                          {"vertex_transformations", stats.vertexTransformations},
                          {"generate_ms", median(genMs)},
                          {"render_ms", median(renderMs)},
                          {"pass1_ms", pass1Ms},
                          {"display", d->name},
                          {"optics", display::opticsKindName(*d)},
                          {"viewer_mm", {viewer.x, viewer.y, viewer.z}},
                          {"container", method == "adaptive" ? a.container : "none"},
                          {"scene", a.scene.empty() ? "built-in exhibit" : a.scene},
                          {"mesh", meshPath},
                          {"frame", framePath},
                          {"overlay", overlayPath}};
    if (uniformLevel >= 0) doc["uniform_level"] = uniformLevel;
    doc.update(memoryJson(*memory));
    if (a.json) {
        printJson(doc);
    } else {
        fmt::print("{} mesh at {} mm: {} vertices, {} triangles, measured max error {:.4f} mm\n",
                   method, a.errorMm, mesh.vertexCount(), mesh.triangleCount(), err.maxErrorMm);
        fmt::print("generation {:.3f} ms, pass 2 {:.3f} ms -> {}, {}, {}\n", median(genMs),
                   median(renderMs), meshPath, overlayPath, framePath);
    }
    if (err.maxErrorMm <= a.errorMm) return kExitOk;
    // The files stay, for a look at where the error lies.
    return fail(
        fmt::format("measured max error {:.4f} mm exceeds --error {:g} mm{} (the files "
                    "above are written)",
                    err.maxErrorMm, a.errorMm,
                    method == "adaptive" && a.gridLevel < 11
                        ? fmt::format(" at --grid-level {}; a finer level (up to 11) "
                                      "lowers it",
                                      a.gridLevel)
                        : ""));
}

}  // namespace

Command registerPredistort(CLI::App& app) {
    auto args = std::make_shared<PredistortArgs>();
    CLI::App* sub = app.add_subcommand(
        "predistort", "Predistort an image for a curved mirror or screen (Bimber et al.)");
    sub->footer(
        "Example: parallax predistort cone_showcase --error 0.5 --out out/cone   (or a display "
        "JSON file)\nWithout --scene a built-in exhibit (pedestal and figure, the scene "
        "'showcase') is fitted to the display's content sphere.");
    sub->add_option("display", args->display,
                    "Display description: a JSON file, or the name of an example built in from "
                    "examples/displays/ (" +
                        exampleDisplayNames() + ") when no such file exists")
        ->required();
    sub->add_option("--viewer", args->viewer, "Viewer position x,y,z in display millimetres "
                                              "(default: the display file's viewer)");
    sub->add_option("--error", args->errorMm, "Image space error threshold in millimetres")
        ->required();
    sub->add_option("--scene", args->scene,
                    "Scene file or generator spec (default: showcase, the built-in exhibit)");
    sub->add_option("--method", args->method, "adaptive (quadtree) or uniform (baseline)");
    sub->add_option("--container", args->container,
                    "Convex container: hull (the coarse convex hull, default), obb or none");
    sub->add_option("--out", args->out, "Output prefix")
        ->required()
        ->check(outputPath(OutputKind::kPrefix));
    sub->add_option("--format", args->format, "Mesh file format: bourke, obj or pfm");
    sub->add_option("--grid-level", args->gridLevel, "Quadtree grid level m (2..11)")
        ->check(CLI::Range(2, 11));
    sub->add_option("--pass1-size", args->pass1Size, "Pass-1 image size in pixels")
        ->check(CLI::Range(16, 8192));
    sub->add_option("--threads", args->threads, "Pass-2 renderer threads (0 = all)")
        ->check(CLI::Range(0, 256));
    sub->add_flag("--json", args->json, "Print the result as JSON");
    return {sub, [args] { return run(*args); }};
}

}  // namespace plx::cli
