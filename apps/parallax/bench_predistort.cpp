// parallax bench predistort: Bimber et al. Table 1 and Figs. 8-10 (uniform against adaptive warp
// meshes) as CSV, JSON and SVG plots.

#include <filesystem>

#include <fmt/format.h>

#include <plx/core/image_io.h>
#include <plx/display/display_json.h>
#include <plx/display/predistort.h>

#include "bench.h"
#include "report.h"

namespace plx::cli {
namespace {

}  // namespace

const char* const kConeShowcaseJson = R"json({
  "name": "Cone-shaped Virtual Showcase (half-silvered conical mirror over a horizontal display)",
  "units": "mm",
  "optics": {"type": "cone_mirror", "bottom_radius": 150, "top_radius": 250, "height": 400},
  "display": {"min": [-600, -600], "max": [600, 600], "framebuffer": [1024, 1024]},
  "viewer": [0, 450, 800],
  "content": {"center": [0, 200, 0], "radius": 150}
})json";

namespace {

struct PredistortBenchArgs {
    std::string display;
    std::string out = "out/bench_predistort";
    std::vector<double> thresholdsMm{8.0, 4.0, 2.0, 1.0, 0.5, 0.1};
    int repetitions = 5;
    int threads = 0;
    int errorDirectionLevel = display::ExperimentConfig{}.errorDirectionLevel;
    std::string container = display::containerKindName(display::ExperimentConfig{}.container);
    bool json = false;
};


}  // namespace

// The SVG plots of Figs. 8-10 (vertex transformations, triangles, time against the threshold)
// from an experiment result.
std::vector<std::pair<std::string, std::string>> predistortPlots(const nlohmann::json& result) {
    struct Figure {
        const char* file;
        const char* title;
        const char* yLabel;
        const char* key;
    };
    const Figure figures[] = {
        {"fig8_vertices.svg", "Fig. 8: vertex transformations", "vertex transformations",
         "vertex_transformations"},
        {"fig9_triangles.svg", "Fig. 9: triangles rendered", "triangles", "triangles"},
        {"fig10_time.svg", "Fig. 10: grid generation + pass-2 render", "ms per frame", "total"},
    };
    std::vector<std::pair<std::string, std::string>> out;
    for (const Figure& f : figures) {
        std::vector<PlotSeries> series = {{"uniform", {}}, {"adaptive A", {}},
                                          {"adaptive B (container)", {}}};
        const char* keys[] = {"uniform", "adaptive_full", "adaptive_container"};
        for (const auto& row : result["rows"]) {
            double x = row["error_mm"].get<double>();
            for (int s = 0; s < 3; ++s) {
                const auto& e = row[keys[s]];
                double y = std::string(f.key) == "total"
                               ? e["generate_ms"].get<double>() + e["render_ms"].get<double>()
                               : e[f.key].get<double>();
                series[size_t(s)].points.emplace_back(x, y);
            }
        }
        PlotSpec spec{f.title, "error threshold (mm)", f.yLabel, true, true};
        out.emplace_back(f.file, svgLinePlot(spec, series));
    }
    return out;
}

namespace {

int runPredistortBench(const PredistortBenchArgs& a) {
    auto d = a.display.empty() ? display::parseDisplayJson(kConeShowcaseJson)
                               : display::loadDisplayFile(a.display);
    if (!d) return fail(d.status());
    std::error_code ec;
    std::filesystem::create_directories(a.out, ec);
    if (ec) return fail(fmt::format("cannot create {}: {}", a.out, ec.message()));
    auto containerKind = display::parseContainerKind(a.container);
    if (!containerKind) return fail(containerKind.status());
    display::ExperimentConfig config;
    config.container = *containerKind;
    config.repetitions = a.repetitions;
    config.thresholdsMm = a.thresholdsMm;
    config.threads = a.threads;
    config.errorDirectionLevel = a.errorDirectionLevel;
    auto content = display::fitSceneToContent(display::makeShowcaseScene(), *d);
    auto result = display::runPredistortExperiment(*d, d->defaultViewerMm, content, config);
    if (!result) return fail(result.status());
    std::string dir = a.out + "/";
    if (Status s = writeText(dir + "table1.json", result->dump(2)); !s) return fail(s);
    std::string csv = display::experimentCsv(*result);
    if (Status s = writeText(dir + "table1.csv", csv); !s) return fail(s);
    for (const auto& [file, svg] : predistortPlots(*result))
        if (Status s = writeText(dir + file, svg); !s) return fail(s);
    if (a.json) {
        printJson(*result);
    } else {
        fmt::print("{}", csv);
        fmt::print("wrote {}table1.{{csv,json}} and fig8-10 SVG plots\n", dir);
    }
    return kExitOk;
}

}  // namespace

Command addBenchPredistort(CLI::App* bench) {
    auto pd = std::make_shared<PredistortBenchArgs>();
    CLI::App* sub = bench->add_subcommand(
        "predistort", "Bimber et al. Table 1, Figs. 8-10: uniform vs adaptive warp meshes");
    sub->footer("Example: parallax bench predistort --out out/bench_predistort");
    sub->add_option("--display", pd->display, "Display description (default: cone showcase)");
    sub->add_option("--out", pd->out, "Output folder");
    sub->add_option("--thresholds", pd->thresholdsMm,
                    "Error thresholds in mm (default: the paper's 8 4 2 1 0.5 0.1)")
        ->delimiter(',');
    sub->add_option("--repetitions", pd->repetitions, "Timed frames per measurement (median)")
        ->check(CLI::Range(1, 100));
    sub->add_option("--threads", pd->threads, "Pass-2 renderer threads (0 = all)")
        ->check(CLI::Range(0, 256));
    sub->add_option("--lambda", pd->errorDirectionLevel,
                    "Error-direction LOD Lambda (section 7.4); above the grid level: off")
        ->check(CLI::Range(0, 99));
    sub->add_option("--container", pd->container,
                    "Container of the limited grid B: hull (default, the coarse convex hull) or "
                    "obb (the paper's Table 1)");
    sub->add_flag("--json", pd->json, "Print the result as JSON");
    return {sub, [pd] { return runPredistortBench(*pd); }};
}

}  // namespace plx::cli
