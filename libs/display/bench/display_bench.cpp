// Mesh generation speed (Bimber et al. section 8): adaptive at 1 mm on one core, and the uniform
// grid needed for the same error; pass 2 (the textured render of a warp mesh) on one thread.

#include <benchmark/benchmark.h>

#include <plx/display/display_json.h>
#include <plx/display/predistort.h>
#include <plx/scene/generators.h>

namespace {

using namespace plx::display;

Display coneDisplay() {
    auto d = loadDisplayFile(PLX_SOURCE_DIR_STR "/examples/displays/cone_showcase.json");
    return d.isOk() ? *d : Display{};
}

// The container of a benchmark argument: 0 none, 1 OBB, 2 the coarse hull (grid B's default).
Container containerOfArg(int64_t arg, const plx::scene::Scene& sceneMm) {
    const ContainerKind kinds[] = {ContainerKind::kNone, ContainerKind::kObb, ContainerKind::kHull};
    return makeContainer(kinds[arg], scenePointsMm(sceneMm));
}

void BM_AdaptiveGenerate(benchmark::State& state) {
    Display d = coneDisplay();
    double thr = double(state.range(0)) / 10.0;
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto scene = fitSceneToContent(*plx::scene::generateShowcase(), d);
    Container c = containerOfArg(state.range(1), scene);  // arg 1: see containerOfArg
    auto warper = QuadtreeWarper::create({9, thr});
    WarpMesh mesh;
    WarpStats stats;
    for (auto _ : state) {
        (*warper)->generate(d, plane, &c, &mesh, &stats);
        benchmark::DoNotOptimize(mesh.indices.data());
    }
    state.counters["triangles"] = double(mesh.triangleCount());
    state.counters["vertex_transformations"] = double(stats.vertexTransformations);
    state.counters["error_samples"] = double(stats.errorSamples);
    state.counters["solver_maps"] = double(stats.solver.forwardEvaluations);
    state.counters["brent_evals"] = double(stats.solver.evaluations);
    state.counters["ray_tests"] = double(stats.containerRayTests);
}
BENCHMARK(BM_AdaptiveGenerate)->Args({20, 1})->Args({10, 0})->Args({10, 1})->Args({5, 1})->Args({1, 0})->Args({1, 1})
    ->Args({10, 2})->Args({1, 2})->Unit(benchmark::kMillisecond);

void BM_UniformGenerate(benchmark::State& state) {
    Display d = coneDisplay();
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    WarpMesh mesh;
    WarpStats stats;
    for (auto _ : state) {
        generateUniform(d, plane, int(state.range(0)), &mesh, &stats);
        benchmark::DoNotOptimize(mesh.indices.data());
    }
    state.counters["triangles"] = double(mesh.triangleCount());
}
BENCHMARK(BM_UniformGenerate)->Arg(6)->Arg(8)->Unit(benchmark::kMillisecond);

void BM_PassTwo(benchmark::State& state) {
    // Args: threshold in 0.1 mm (0: the uniform grid of level 8), container (0 none, 1 OBB,
    // 2 hull). Pass 2 on one renderer thread, the pass-1 image at 512^2.
    Display d = coneDisplay();
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto scene = fitSceneToContent(*plx::scene::generateShowcase(), d);
    auto pass2 = PredistortRenderer::create(1);
    if (!pass2.isOk()) {
        state.SkipWithError(pass2.status().toString().c_str());
        return;
    }
    if (!renderViewerImage((*pass2)->renderer(), scene, plane, 512, &(*pass2)->viewerImage(),
                           nullptr)
             .isOk()) {
        state.SkipWithError("pass 1 failed");
        return;
    }
    Container c = containerOfArg(state.range(1), scene);
    WarpMesh mesh;
    WarpStats stats;
    if (state.range(0) == 0) {
        generateUniform(d, plane, 8, &mesh, &stats);
    } else {
        auto warper = QuadtreeWarper::create({9, double(state.range(0)) / 10.0});
        (*warper)->generate(d, plane, &c, &mesh, &stats);
    }
    const plx::Image<plx::Rgba8>* frame = nullptr;
    for (auto _ : state) {
        auto out = (*pass2)->render(d, mesh);
        if (!out.isOk()) {
            state.SkipWithError(out.status().toString().c_str());
            return;
        }
        frame = *out;
        benchmark::DoNotOptimize(frame->data());
    }
    size_t lit = 0;
    for (size_t i = 0; frame && i < frame->pixelCount(); ++i) {
        plx::Rgba8 p = frame->data()[i];
        lit += (p.r | p.g | p.b) != 0;
    }
    state.counters["triangles"] = double(mesh.triangleCount());
    state.counters["nonblack_px"] = double(lit);
}
BENCHMARK(BM_PassTwo)->Args({20, 1})->Args({5, 1})->Args({1, 1})->Args({20, 2})->Args({1, 2})
    ->Args({0, 0})->Unit(benchmark::kMillisecond);

}  // namespace
