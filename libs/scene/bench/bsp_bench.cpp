// Fu, Bao, Peng's scene structures on the office: the BSP tree (Fuchs, Kedem, Naylor) - build
// time, fragments per triangle, the front-to-back walk - and the box hierarchy - build time and
// the per-hole query for a 32x32 hole. Counters: Mtri/s of source triangles.

#include <map>
#include <memory>

#include <benchmark/benchmark.h>

#include <plx/scene/box_hierarchy.h>
#include <plx/scene/bsp.h>
#include <plx/scene/generators.h>

namespace {

using plx::scene::BoxHierarchy;
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

// office:8, :64 and :290 (29k, 232k and 1.05M triangles).
void officeSizes(benchmark::internal::Benchmark* b) {
    b->ArgName("office")->Arg(8)->Arg(64)->Arg(290);
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
BENCHMARK(bspBuild)->Apply(officeSizes)->Unit(benchmark::kMillisecond);

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
BENCHMARK(bspFrontToBack)->Apply(officeSizes)->Unit(benchmark::kMillisecond);

// threads:1 builds on the calling thread; threads:2 hands the subtrees below the top levels to a
// pool of two (the same hierarchy).
void boxHierarchyBuild(benchmark::State& state) {
    const Scene* scene = officeScene(int(state.range(0)));
    if (!scene) return state.SkipWithError("office generation failed");
    const int threads = int(state.range(1));
    plx::ThreadPool pool(threads);
    BoxHierarchy hierarchy;
    for (auto _ : state) {
        auto built = BoxHierarchy::build(*scene, {}, threads > 1 ? &pool : nullptr);
        if (!built) return state.SkipWithError(built.status().message().c_str());
        hierarchy = std::move(*built);
    }
    state.counters["triangles"] = double(scene->triangleCount());
    state.counters["nodes"] = double(hierarchy.nodeCount());
    state.counters["depth"] = double(hierarchy.maxDepth());
    state.counters["Mtri/s"] = benchmark::Counter(double(scene->triangleCount()) * 1e-6,
                                                  benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(boxHierarchyBuild)
    ->ArgsProduct({{8, 64, 290}, {1, 2}})
    ->ArgNames({"office", "threads"})
    ->Unit(benchmark::kMillisecond);

// One markHole query: a 32x32 hole at the centre of the default view at 1280x720, the flags
// reused between iterations as between holes.
void boxHierarchyHole32(benchmark::State& state) {
    const Scene* scene = officeScene(int(state.range(0)));
    if (!scene) return state.SkipWithError("office generation failed");
    auto hierarchy = BoxHierarchy::build(*scene);
    if (!hierarchy) return state.SkipWithError(hierarchy.status().message().c_str());
    auto camera = plx::scene::cameraAt(*scene, plx::scene::defaultViewpoint(*scene), 1280, 720);
    if (!camera) return state.SkipWithError(camera.status().message().c_str());
    plx::scene::HoleFlags flags;
    plx::scene::HoleQueryStats stats;
    for (auto _ : state) hierarchy->markHole(*camera, {624, 344, 656, 376}, &flags, &stats);
    state.counters["triangles"] = double(scene->triangleCount());
    state.counters["positive"] = double(stats.trianglesPositive);
    state.counters["tested"] = double(stats.nodesTested);
    state.counters["rejected"] = double(stats.nodesRejected);
}
BENCHMARK(boxHierarchyHole32)->Apply(officeSizes)->Unit(benchmark::kMicrosecond);

}  // namespace
