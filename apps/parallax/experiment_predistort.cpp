// The experiment of Bimber et al. section 8: Table 1 and Figs. 8-10 for one viewer.

#include "experiment_predistort.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include <plx/core/parallel.h>
#include <plx/core/timing.h>
#include <plx/display/display_json.h>
#include <plx/display/validate.h>

#include "report.h"

namespace plx::cli {
namespace {

// Lattice divisions per triangle edge for the dense error measurement.
constexpr int kValidationDivisions = 4;
constexpr int kMaxUniformLevel = 10;

struct Timed {
    double generateMs = 0.0;
    double renderMs = 0.0;
};

nlohmann::json adaptiveJson(const AdaptiveGridResult& g) {
    return {{"vertex_transformations", g.stats.vertexTransformations},
            {"triangles", g.triangles},
            {"patches", g.stats.patches},
            {"error_samples", g.stats.errorSamples},
            {"solver_evaluations", g.stats.solver.evaluations},
            {"newton_solves", g.stats.solver.newtonSolves},
            {"solver_forward_evaluations", g.stats.solver.forwardEvaluations},
            {"generate_ms", g.generateMs},
            {"render_ms", g.renderMs},
            {"max_measured_error_mm", g.maxMeasuredErrorMm},
            {"speedup_grid", g.speedupGrid},
            {"speedup", g.speedup}};
}

}  // namespace

Status checkPredistortThresholds(const std::vector<double>& thresholdsMm) {
    if (thresholdsMm.empty())
        return errorStatus(ErrorCode::kInvalidArgument, "no error thresholds given");
    for (double t : thresholdsMm)
        if (!std::isfinite(t) || t <= 0.0)
            return errorStatus(
                ErrorCode::kInvalidArgument,
                fmt::format("error threshold {:g} mm must be a finite number > 0", t));
    return Status::ok();
}

double predistortImageBytes(const display::Display& display, int pass1Size,
                            double framebufferBytesPerPixel) {
    constexpr double kPass1BytesPerPixel = 13.0;  // see the header
    const double framebufferPixels =
        double(display.framebufferWidth) * double(display.framebufferHeight);
    return framebufferBytesPerPixel * framebufferPixels +
           kPass1BytesPerPixel * double(pass1Size) * double(pass1Size);
}

Result<PredistortExperiment> runPredistortExperiment(const display::Display& display,
                                                     const display::DVec3& viewerMm,
                                                     const scene::Scene& sceneMm,
                                                     const PredistortExperimentConfig& config) {
    using namespace display;
    PLX_RETURN_IF_ERROR(checkPredistortThresholds(config.thresholdsMm));
    if (config.repetitions < 1 || config.repetitions > 1000)
        return errorStatus(ErrorCode::kInvalidArgument, "repetitions must lie in [1, 1000]");
    Display viewed = display;
    viewed.defaultViewerMm = viewerMm;
    PLX_RETURN_IF_ERROR(validateDisplay(viewed));
    ImagePlane plane = makeImagePlane(viewerMm, display.contentCenterMm, display.contentRadiusMm);
    QuadtreeConfig warpConfig;
    warpConfig.gridLevel = config.gridLevel;
    warpConfig.thresholdMm = config.thresholdsMm[0];
    warpConfig.errorDirectionLevel = config.errorDirectionLevel;
    auto warper = QuadtreeWarper::create(warpConfig);
    if (!warper) return warper.status();
    auto pass2 = PredistortRenderer::create(config.threads);
    if (!pass2) return pass2.status();
    // Pass 1 straight into the image pass 2 samples: its frames copy nothing.
    PLX_RETURN_IF_ERROR(renderViewerImage((*pass2)->renderer(), sceneMm, plane, config.pass1Size,
                                          &(*pass2)->viewerImage(), nullptr));
    Container container = makeContainer(config.container, scenePointsMm(sceneMm));
    ThreadPool pool(0);

    auto timeRender = [&](const WarpMesh& mesh) -> double {
        if (!config.render) return 0.0;
        std::vector<double> ms;
        // One warm-up frame sizes the renderer's scratch and the framebuffers.
        if (!(*pass2)->render(display, mesh).isOk()) return 0.0;
        for (int r = 0; r < config.repetitions; ++r) {
            Stopwatch sw;
            if (!(*pass2)->render(display, mesh).isOk()) return 0.0;
            ms.push_back(sw.elapsedMs());
        }
        return median(ms);
    };
    auto runAdaptive = [&](double thr, const Container* c, WarpMesh* mesh, WarpStats* stats) {
        (*warper)->setThresholdMm(thr);
        std::vector<double> ms;
        (*warper)->generate(display, plane, c, mesh, stats);  // warm-up: buffers reach size
        for (int r = 0; r < config.repetitions; ++r) {
            Stopwatch sw;
            (*warper)->generate(display, plane, c, mesh, stats);
            ms.push_back(sw.elapsedMs());
        }
        return Timed{median(ms), timeRender(*mesh)};
    };

    // Measured maximum error of each uniform level, computed on demand.
    std::map<int, double> uniformError;
    auto uniformMaxError = [&](int level) {
        auto it = uniformError.find(level);
        if (it != uniformError.end()) return it->second;
        WarpMesh mesh;
        WarpStats stats;
        generateUniform(display, plane, level, &mesh, &stats);
        double e = measureMeshError(display, plane, mesh, kValidationDivisions, &pool).maxErrorMm;
        uniformError[level] = e;
        return e;
    };

    PredistortExperiment out;
    out.display = display.name;
    out.optics = opticsKindName(display);
    out.viewerMm = viewerMm;
    out.config = config;
    out.errorDirectionRecheck = warpConfig.errorDirectionRecheck;
    out.rendererThreads = (*pass2)->renderer().threadCount();
    for (double thr : config.thresholdsMm) {
        PredistortExperimentRow row;
        row.errorMm = thr;
        int level = 1;
        while (level < kMaxUniformLevel && uniformMaxError(level) > thr) ++level;
        WarpMesh uni;
        std::vector<double> uniMs;
        generateUniform(display, plane, level, &uni, &row.uniform.stats);  // warm-up, as above
        for (int r = 0; r < config.repetitions; ++r) {
            Stopwatch sw;
            generateUniform(display, plane, level, &uni, &row.uniform.stats);
            uniMs.push_back(sw.elapsedMs());
        }
        Timed u{median(uniMs), timeRender(uni)};
        row.uniform.level = level;
        row.uniform.triangles = uni.triangleCount();
        row.uniform.generateMs = u.generateMs;
        row.uniform.renderMs = u.renderMs;
        row.uniform.maxMeasuredErrorMm = uniformMaxError(level);

        WarpMesh meshA, meshB;
        Timed a = runAdaptive(thr, nullptr, &meshA, &row.adaptiveFull.stats);
        Timed b = runAdaptive(thr, &container, &meshB, &row.adaptiveContainer.stats);
        double uniTotal = u.generateMs + u.renderMs;
        auto fill = [&](const WarpMesh& m, const Timed& t, AdaptiveGridResult* g) {
            g->triangles = m.triangleCount();
            g->generateMs = t.generateMs;
            g->renderMs = t.renderMs;
            g->maxMeasuredErrorMm =
                measureMeshError(display, plane, m, kValidationDivisions, &pool).maxErrorMm;
            g->speedupGrid = u.generateMs / std::max(t.generateMs, 1e-9);
            g->speedup = uniTotal / std::max(t.generateMs + t.renderMs, 1e-9);
        };
        fill(meshA, a, &row.adaptiveFull);
        fill(meshB, b, &row.adaptiveContainer);
        out.rows.push_back(row);
    }
    return out;
}

nlohmann::json predistortExperimentJson(const PredistortExperiment& e) {
    nlohmann::json rows = nlohmann::json::array();
    for (const PredistortExperimentRow& r : e.rows)
        rows.push_back({{"error_mm", r.errorMm},
                        {"uniform",
                         {{"level", r.uniform.level},
                          {"vertex_transformations", r.uniform.stats.vertexTransformations},
                          {"triangles", r.uniform.triangles},
                          {"generate_ms", r.uniform.generateMs},
                          {"render_ms", r.uniform.renderMs},
                          {"max_measured_error_mm", r.uniform.maxMeasuredErrorMm}}},
                        {"adaptive_full", adaptiveJson(r.adaptiveFull)},
                        {"adaptive_container", adaptiveJson(r.adaptiveContainer)}});
    return {{"display", e.display},
            {"optics", e.optics},
            {"viewer_mm", {e.viewerMm.x, e.viewerMm.y, e.viewerMm.z}},
            {"grid_level", e.config.gridLevel},
            {"error_direction_level", e.config.errorDirectionLevel},
            {"error_direction_recheck", e.errorDirectionRecheck},
            {"container", display::containerKindName(e.config.container)},
            {"renderer_threads", e.rendererThreads},
            {"generation_threads", 1},
            {"pass2_texture", "base level only, no mip chain"},
            {"rows", rows}};
}

std::string predistortExperimentCsv(const PredistortExperiment& e) {
    std::string out =
        "error_mm,uniform_level,uniform_vt,uniform_tri,uniform_ms,uniform_err,"
        "a_vt,a_tri,a_gen_ms,a_render_ms,a_err,a_speedup_grid,a_speedup,"
        "b_vt,b_tri,b_gen_ms,b_render_ms,b_err,b_speedup_grid,b_speedup\n";
    for (const PredistortExperimentRow& r : e.rows) {
        const UniformGridResult& u = r.uniform;
        const AdaptiveGridResult& a = r.adaptiveFull;
        const AdaptiveGridResult& b = r.adaptiveContainer;
        out += fmt::format(
            "{},{},{},{},{:.3f},{:.4f},{},{},{:.3f},{:.3f},{:.4f},{:.2f},{:.2f},{},{},{:.3f},"
            "{:.3f},{:.4f},{:.2f},{:.2f}\n",
            r.errorMm, u.level, u.stats.vertexTransformations, u.triangles,
            u.generateMs + u.renderMs, u.maxMeasuredErrorMm, a.stats.vertexTransformations,
            a.triangles, a.generateMs, a.renderMs, a.maxMeasuredErrorMm, a.speedupGrid, a.speedup,
            b.stats.vertexTransformations, b.triangles, b.generateMs, b.renderMs,
            b.maxMeasuredErrorMm, b.speedupGrid, b.speedup);
    }
    return out;
}

std::vector<std::pair<std::string, std::string>> predistortPlots(const PredistortExperiment& e) {
    struct Figure {
        const char* file;
        const char* title;
        const char* yLabel;
        double (*value)(double vertexTransformations, double triangles, double ms);
    };
    const Figure figures[] = {
        {"fig8_vertices.svg", "Fig. 8: vertex transformations", "vertex transformations",
         [](double vt, double, double) { return vt; }},
        {"fig9_triangles.svg", "Fig. 9: triangles rendered", "triangles",
         [](double, double tri, double) { return tri; }},
        {"fig10_time.svg", "Fig. 10: grid generation + pass-2 render", "ms per frame",
         [](double, double, double ms) { return ms; }},
    };
    std::vector<std::pair<std::string, std::string>> out;
    for (const Figure& f : figures) {
        std::vector<PlotSeries> series = {
            {"uniform", {}}, {"adaptive A", {}}, {"adaptive B (container)", {}}};
        for (const PredistortExperimentRow& r : e.rows) {
            const UniformGridResult& u = r.uniform;
            series[0].points.emplace_back(
                r.errorMm, f.value(double(u.stats.vertexTransformations), double(u.triangles),
                                   u.generateMs + u.renderMs));
            const AdaptiveGridResult* grids[] = {&r.adaptiveFull, &r.adaptiveContainer};
            for (int s = 0; s < 2; ++s)
                series[size_t(s + 1)].points.emplace_back(
                    r.errorMm, f.value(double(grids[s]->stats.vertexTransformations),
                                       double(grids[s]->triangles),
                                       grids[s]->generateMs + grids[s]->renderMs));
        }
        PlotSpec spec{f.title, "error threshold (mm)", f.yLabel, true, true};
        out.emplace_back(f.file, svgLinePlot(spec, series));
    }
    return out;
}

}  // namespace plx::cli
