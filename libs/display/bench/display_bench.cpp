// Mesh generation speed (Bimber et al. section 8): adaptive at 1 mm on one core, and the uniform
// grid needed for the same error.

#include <benchmark/benchmark.h>

#include <plx/display/display_json.h>
#include <plx/display/predistort.h>

namespace {

using namespace plx::display;

Display coneDisplay() {
    auto d = loadDisplayFile(PLX_SOURCE_DIR_STR "/examples/displays/cone_showcase.json");
    return d.isOk() ? *d : Display{};
}

void BM_AdaptiveGenerate(benchmark::State& state) {
    Display d = coneDisplay();
    double thr = double(state.range(0)) / 10.0;
    ImagePlane plane = makeImagePlane(d.defaultViewerMm, d.contentCenterMm, d.contentRadiusMm);
    auto scene = fitSceneToContent(makeShowcaseScene(), d);
    Container c = makeContainer(state.range(1) ? ContainerKind::kObb : ContainerKind::kNone,
                                scenePointsMm(scene));
    auto warper = QuadtreeWarper::create({9, thr});
    WarpMesh mesh;
    WarpStats stats;
    for (auto _ : state) {
        (*warper)->generate(d, plane, &c, &mesh, &stats);
        benchmark::DoNotOptimize(mesh.indices.data());
    }
    state.counters["triangles"] = double(mesh.triangleCount());
    state.counters["vertex_transformations"] = double(stats.vertexTransformations);
}
BENCHMARK(BM_AdaptiveGenerate)->Args({20, 1})->Args({10, 0})->Args({10, 1})->Args({5, 1})->Args({1, 0})->Args({1, 1})
    ->Unit(benchmark::kMillisecond);

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

}  // namespace

BENCHMARK_MAIN();
