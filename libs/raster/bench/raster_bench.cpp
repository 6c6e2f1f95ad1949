// Google Benchmark for the rasterizer's hot path (Mtri/s and Mpix/s on procedural scenes).
#include <random>

#include <benchmark/benchmark.h>

#include <plx/raster/raster.h>

namespace {

using namespace plx;

// A sphere-ish cloud of n small random triangles in front of the camera.
scene::Scene smallTriangles(int n) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    scene::Scene s;
    scene::Mesh m;
    for (int i = 0; i < n; ++i) {
        Vec3 c(u(rng) * 4.0f, u(rng) * 2.5f, -5.0f + u(rng) * 2.0f);
        for (int k = 0; k < 3; ++k) {
            m.positions.push_back(c + Vec3(u(rng), u(rng), u(rng)) * 0.03f);
            m.indices.push_back(uint32_t(m.positions.size() - 1));
        }
    }
    s.meshes.push_back(std::move(m));
    PLX_CHECK(s.finalize().isOk());
    return s;
}

void BM_RenderSmallTriangles(benchmark::State& state) {
    scene::Scene s = smallTriangles(int(state.range(0)));
    CameraDesc d;
    d.eyePos = {0, 0, 0};
    d.targetPos = {0, 0, -1};
    Camera cam = *Camera::create(d);
    auto r = std::move(raster::Renderer::create({int(state.range(1)), 64})).value();
    raster::FrameBuffers fb;
    fb.resize(d.width, d.height);
    for (auto _ : state) r->render(s, cam, {}, fb.targets());
    state.counters["Mtri/s"] = benchmark::Counter(double(s.triangleCount()) * state.iterations() / 1e6,
                                                  benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderSmallTriangles)->Args({100000, 1})->Args({100000, 2})->Args({1000000, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
