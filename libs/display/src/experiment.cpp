// The experiment of Bimber et al. section 8: Table 1 and Figs. 8-10 for one viewer.

#include <plx/display/predistort.h>

#include <map>

#include <fmt/format.h>

#include <plx/core/parallel.h>
#include <plx/core/timing.h>
#include <plx/display/display_json.h>
#include <plx/display/validate.h>

namespace plx::display {
namespace {

// Lattice divisions per triangle edge for the dense error measurement.
constexpr int kValidationDivisions = 4;
constexpr int kMaxUniformLevel = 10;

struct Timed {
    double generateMs = 0.0;
    double renderMs = 0.0;
};

}  // namespace

Result<nlohmann::json> runPredistortExperiment(const Display& display, const DVec3& viewerMm,
                                               const scene::Scene& sceneMm,
                                               const ExperimentConfig& config) {
    if (config.thresholdsMm.empty())
        return errorStatus(ErrorCode::kInvalidArgument, "no error thresholds given");
    for (double t : config.thresholdsMm)
        if (!std::isfinite(t) || t <= 0.0)
            return errorStatus(ErrorCode::kInvalidArgument, "thresholds must be positive");
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

    nlohmann::json rows = nlohmann::json::array();
    for (double thr : config.thresholdsMm) {
        int level = 1;
        while (level < kMaxUniformLevel && uniformMaxError(level) > thr) ++level;
        WarpMesh uni;
        WarpStats uniStats;
        std::vector<double> uniMs;
        generateUniform(display, plane, level, &uni, &uniStats);  // warm-up, as above
        for (int r = 0; r < config.repetitions; ++r) {
            Stopwatch sw;
            generateUniform(display, plane, level, &uni, &uniStats);
            uniMs.push_back(sw.elapsedMs());
        }
        Timed u{median(uniMs), timeRender(uni)};

        WarpMesh meshA, meshB;
        WarpStats statsA, statsB;
        Timed a = runAdaptive(thr, nullptr, &meshA, &statsA);
        Timed b = runAdaptive(thr, &container, &meshB, &statsB);
        double errA = measureMeshError(display, plane, meshA, kValidationDivisions, &pool).maxErrorMm;
        double errB = measureMeshError(display, plane, meshB, kValidationDivisions, &pool).maxErrorMm;
        double uniTotal = u.generateMs + u.renderMs;
        double uniGen = u.generateMs;
        auto entry = [&](const WarpMesh& m, const WarpStats& s, const Timed& t, double err) {
            return nlohmann::json{{"vertex_transformations", s.vertexTransformations},
                                  {"triangles", m.triangleCount()},
                                  {"patches", s.patches},
                                  {"error_samples", s.errorSamples},
                                  {"solver_evaluations", s.solver.evaluations},
                                  {"newton_solves", s.solver.newtonSolves},
                                  {"solver_forward_evaluations", s.solver.forwardEvaluations},
                                  {"generate_ms", t.generateMs},
                                  {"render_ms", t.renderMs},
                                  {"max_measured_error_mm", err},
                                  {"speedup_grid", uniGen / std::max(t.generateMs, 1e-9)},
                                  {"speedup", uniTotal / std::max(t.generateMs + t.renderMs, 1e-9)}};
        };
        rows.push_back({{"error_mm", thr},
                        {"uniform",
                         {{"level", level},
                          {"vertex_transformations", uniStats.vertexTransformations},
                          {"triangles", uni.triangleCount()},
                          {"generate_ms", u.generateMs},
                          {"render_ms", u.renderMs},
                          {"max_measured_error_mm", uniformMaxError(level)}}},
                        {"adaptive_full", entry(meshA, statsA, a, errA)},
                        {"adaptive_container", entry(meshB, statsB, b, errB)}});
    }
    return nlohmann::json{{"display", display.name},
                          {"optics", opticsKindName(display)},
                          {"viewer_mm", {viewerMm.x, viewerMm.y, viewerMm.z}},
                          {"grid_level", config.gridLevel},
                          {"error_direction_level", config.errorDirectionLevel},
                          {"error_direction_recheck", warpConfig.errorDirectionRecheck},
                          {"container", containerKindName(config.container)},
                          {"renderer_threads", (*pass2)->renderer().threadCount()},
                          {"generation_threads", 1},
                          {"pass2_texture", "base level only, no mip chain"},
                          {"rows", rows}};
}

std::string experimentCsv(const nlohmann::json& result) {
    std::string out =
        "error_mm,uniform_level,uniform_vt,uniform_tri,uniform_ms,uniform_err,"
        "a_vt,a_tri,a_gen_ms,a_render_ms,a_err,a_speedup_grid,a_speedup,"
        "b_vt,b_tri,b_gen_ms,b_render_ms,b_err,b_speedup_grid,b_speedup\n";
    for (const auto& r : result["rows"]) {
        const auto& u = r["uniform"];
        const auto& a = r["adaptive_full"];
        const auto& b = r["adaptive_container"];
        out += fmt::format(
            "{},{},{},{},{:.3f},{:.4f},{},{},{:.3f},{:.3f},{:.4f},{:.2f},{:.2f},{},{},{:.3f},"
            "{:.3f},{:.4f},{:.2f},{:.2f}\n",
            r["error_mm"].get<double>(), u["level"].get<int>(),
            u["vertex_transformations"].get<uint64_t>(), u["triangles"].get<uint64_t>(),
            u["generate_ms"].get<double>() + u["render_ms"].get<double>(),
            u["max_measured_error_mm"].get<double>(), a["vertex_transformations"].get<uint64_t>(),
            a["triangles"].get<uint64_t>(), a["generate_ms"].get<double>(),
            a["render_ms"].get<double>(), a["max_measured_error_mm"].get<double>(),
            a["speedup_grid"].get<double>(), a["speedup"].get<double>(),
            b["vertex_transformations"].get<uint64_t>(),
            b["triangles"].get<uint64_t>(), b["generate_ms"].get<double>(),
            b["render_ms"].get<double>(), b["max_measured_error_mm"].get<double>(),
            b["speedup_grid"].get<double>(), b["speedup"].get<double>());
    }
    return out;
}

}  // namespace plx::display
