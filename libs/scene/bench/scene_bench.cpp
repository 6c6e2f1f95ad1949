// Scene generation and import speed: Mtri/s for the generators, milliseconds for the helmet.

#include <filesystem>

#include <benchmark/benchmark.h>

#include <plx/scene/generators.h>
#include <plx/scene/import.h>

namespace {

void reportTriangles(benchmark::State& state, size_t triangles) {
    state.counters["triangles"] = double(triangles);
    state.counters["Mtri/s"] = benchmark::Counter(double(triangles) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

void generateOffice(benchmark::State& state) {
    size_t triangles = 0;
    for (auto _ : state) {
        auto scene = plx::scene::generateOffice(int(state.range(0)));
        if (!scene) state.SkipWithError(scene.status().message().c_str());
        else triangles = scene->triangleCount();
    }
    reportTriangles(state, triangles);
}
BENCHMARK(generateOffice)->Arg(1)->Arg(15)->Arg(256)->Unit(benchmark::kMillisecond);

void generateMuseum(benchmark::State& state) {
    size_t triangles = 0;
    for (auto _ : state) {
        auto scene = plx::scene::generateMuseum(int(state.range(0)));
        if (!scene) state.SkipWithError(scene.status().message().c_str());
        else triangles = scene->triangleCount();
    }
    reportTriangles(state, triangles);
}
BENCHMARK(generateMuseum)->Arg(1)->Arg(16)->Unit(benchmark::kMillisecond);

void importHelmet(benchmark::State& state) {
    std::string path = std::string(PLX_SHARED_DATA_DIR) + "/models/DamagedHelmet/DamagedHelmet.glb";
    if (!std::filesystem::exists(path)) {
        state.SkipWithError("shared data absent: DamagedHelmet.glb");
        return;
    }
    plx::scene::ImportOptions options;
    options.loadTextures = state.range(0) != 0;
    size_t triangles = 0;
    for (auto _ : state) {
        auto scene = plx::scene::importFile(path, options);
        if (!scene) state.SkipWithError(scene.status().message().c_str());
        else triangles = scene->triangleCount();
    }
    reportTriangles(state, triangles);
}
BENCHMARK(importHelmet)->ArgName("textures")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
