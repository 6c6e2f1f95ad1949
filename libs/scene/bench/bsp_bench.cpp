// BSP tree (Fuchs, Kedem, Naylor) on the office: build time, fragments per triangle, and the
// front-to-back walk Fu, Bao, Peng run per frame. Counters: Mtri/s of source triangles.

#include <map>
#include <memory>

#include <benchmark/benchmark.h>

#include <plx/scene/bsp.h>
#include <plx/scene/generators.h>

namespace {

using plx::scene::BspTree;
using plx::scene::Scene;

// Office scenes are generated once per process: generation is not what these benchmarks time.
const Scene* officeScene(int rooms) {
    static std::map<int, std::unique_ptr<Scene>> cache;
    auto& slot = cache[rooms];
    if (!slot) {
        auto scene = plx::scene::generateOffice(rooms);
        if (!scene) return nullptr;
        slot = std::make_unique<Scene>(std::move(*scene));
    }
    return slot.get();
}

void reportTree(benchmark::State& state, const Scene& scene, const BspTree& tree) {
    const auto& s = tree.stats();
    state.counters["triangles"] = double(scene.triangleCount());
    state.counters["fragments"] = double(s.fragments);
    state.counters["frag/tri"] = s.fragmentsPerTriangle();
    state.counters["nodes"] = double(s.nodes);
    state.counters["depth"] = double(s.maxDepth);
    state.counters["MB"] = double(s.memoryBytes) / double(1 << 20);
    state.counters["Mtri/s"] = benchmark::Counter(double(scene.triangleCount()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

void bspBuild(benchmark::State& state) {
    const Scene* scene = officeScene(int(state.range(0)));
    if (!scene) return state.SkipWithError("office generation failed");
    BspTree tree;
    for (auto _ : state) {
        auto built = BspTree::build(*scene);
        if (!built) return state.SkipWithError(built.status().message().c_str());
        tree = std::move(*built);
    }
    reportTree(state, *scene, tree);
}
BENCHMARK(bspBuild)->ArgName("office")->Arg(8)->Arg(64)->Arg(290)->Unit(benchmark::kMillisecond);

// The walk from the office's default viewpoint, writing every fragment index in order.
void bspFrontToBack(benchmark::State& state) {
    const Scene* scene = officeScene(int(state.range(0)));
    if (!scene) return state.SkipWithError("office generation failed");
    auto tree = BspTree::build(*scene);
    if (!tree) return state.SkipWithError(tree.status().message().c_str());
    plx::Vec3 eyePos = plx::scene::defaultViewpoint(*scene).eyePos;
    std::vector<uint32_t> order;
    for (auto _ : state) {
        tree->frontToBack(eyePos, &order);
        benchmark::DoNotOptimize(order.data());
    }
    reportTree(state, *scene, *tree);
}
BENCHMARK(bspFrontToBack)
    ->ArgName("office")
    ->Arg(8)
    ->Arg(64)
    ->Arg(290)
    ->Unit(benchmark::kMillisecond);

}  // namespace
