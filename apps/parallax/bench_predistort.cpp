// parallax bench predistort: Bimber et al. Table 1 and Figs. 8-10 (uniform against adaptive warp
// meshes) as CSV, JSON and SVG plots.

#include <fmt/format.h>

#include <plx/scene/generators.h>

#include "bench.h"
#include "example_displays.h"
#include "experiment_predistort.h"

namespace plx::cli {
namespace {

struct PredistortBenchArgs {
    std::string display = "cone_showcase";
    std::string out = "out/bench_predistort";
    std::vector<double> thresholdsMm{8.0, 4.0, 2.0, 1.0, 0.5, 0.1};
    int repetitions = 5;
    int threads = 0;
    int errorDirectionLevel = PredistortExperimentConfig{}.errorDirectionLevel;
    std::string container = display::containerKindName(PredistortExperimentConfig{}.container);
    bool json = false;
};

int runPredistortBench(const PredistortBenchArgs& a) {
    if (Status s = checkPredistortThresholds(a.thresholdsMm); !s)
        return fail("--thresholds: " + s.message(), kExitUsage);
    auto d = loadDisplayArgument(a.display);
    if (!d) return fail(d.status());
    auto containerKind = display::parseContainerKind(a.container);
    if (!containerKind) return fail(containerKind.status().message(), kExitUsage);
    PredistortExperimentConfig config;
    config.container = *containerKind;
    config.repetitions = a.repetitions;
    config.thresholdsMm = a.thresholdsMm;
    config.threads = a.threads;
    config.errorDirectionLevel = a.errorDirectionLevel;
    auto showcase = scene::generateShowcase();
    if (!showcase) return fail(showcase.status());
    auto content = display::fitSceneToContent(*showcase, *d);
    auto memory = startExperiment(
        "bench predistort", d->framebufferWidth, d->framebufferHeight,
        predistortImageBytes(*d, config.pass1Size, kPredistortExperimentBytesPerPixel), a.out);
    if (!memory) return fail(memory.status());
    auto result = runPredistortExperiment(*d, d->defaultViewerMm, content, config);
    if (!result) return fail(result.status());
    auto files = predistortPlots(*result);
    const std::string csv = predistortExperimentCsv(*result);
    files.emplace_back("table1.csv", csv);
    nlohmann::json doc = predistortExperimentJson(*result);
    doc.update(memoryJson(*memory));
    return finishExperiment(a.out, a.json, doc, "table1.json", std::move(files),
                            [&](const std::string& dir) {
                                fmt::print("{}", csv);
                                fmt::print("wrote {}table1.{{csv,json}} and fig8-10 SVG plots\n",
                                           dir);
                            });
}

}  // namespace

Command addBenchPredistort(CLI::App* bench) {
    auto pd = std::make_shared<PredistortBenchArgs>();
    CLI::App* sub = bench->add_subcommand(
        "predistort", "Bimber et al. Table 1, Figs. 8-10: uniform vs adaptive warp meshes");
    sub->footer("Example: parallax bench predistort --out out/bench_predistort");
    sub->add_option("--display", pd->display,
                    "Display description: a JSON file, or the name of an example built in from "
                    "examples/displays/ (" +
                        exampleDisplayNames() + ") when no such file exists")
        ->capture_default_str();
    sub->add_option("--out", pd->out, "Output folder")->check(outputPath(OutputKind::kFolder));
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
                    "Container of the limited grid B: hull (default, the coarse convex hull), "
                    "obb (the paper's Table 1) or none");
    sub->add_flag("--json", pd->json, "Print the result as JSON");
    return {sub, [pd] { return runPredistortBench(*pd); }};
}

}  // namespace plx::cli
