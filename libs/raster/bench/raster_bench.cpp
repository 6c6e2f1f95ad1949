// Google Benchmark for the rasterizer's hot path (Mtri/s and Mpix/s on procedural scenes).
#include <cmath>
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

// A grid of UV spheres (rings x 2 rings segments each): spatially coherent meshes like real
// models, with shared vertices.
scene::Scene sphereGrid(int spheres, int rings) {
    scene::Scene s;
    int side = int(std::ceil(std::sqrt(double(spheres))));
    for (int i = 0; i < spheres; ++i) {
        scene::Mesh m;
        Vec3 c(float(i % side) - 0.5f * float(side - 1), float(i / side) - 0.5f * float(side - 1),
               -float(side) * 1.1f);
        int segments = 2 * rings;
        for (int r = 0; r <= rings; ++r) {
            float phi = kPi * float(r) / float(rings);
            for (int g = 0; g <= segments; ++g) {
                float theta = 2.0f * kPi * float(g) / float(segments);
                Vec3 n(std::sin(phi) * std::cos(theta), std::cos(phi), -std::sin(phi) * std::sin(theta));
                m.positions.push_back(c + 0.45f * n);
                m.normals.push_back(n);
            }
        }
        for (int r = 0; r < rings; ++r)
            for (int g = 0; g < segments; ++g) {
                uint32_t a = uint32_t(r * (segments + 1) + g), b = a + 1,
                         cc = a + uint32_t(segments + 1), d = cc + 1;
                m.indices.insert(m.indices.end(), {a, cc, b, b, cc, d});
            }
        s.meshes.push_back(std::move(m));
    }
    PLX_CHECK(s.finalize().isOk());
    return s;
}

// Renders `s` from the origin looking down -z at 1280x720 with state.range(1) threads and
// reports Mtri/s and the visible triangle count.
void renderLoop(benchmark::State& state, const scene::Scene& s, float fovYDegrees) {
    CameraDesc d;
    d.eyePos = {0, 0, 0};
    d.targetPos = {0, 0, -1};
    d.fovYDegrees = fovYDegrees;
    Camera cam = *Camera::create(d);
    auto r = std::move(raster::Renderer::create({int(state.range(1))})).value();
    raster::FrameBuffers fb;
    fb.resize(d.width, d.height);
    for (auto _ : state) r->render(s, cam, {}, fb.targets());
    state.counters["Mtri/s"] = benchmark::Counter(double(s.triangleCount()) * state.iterations() / 1e6,
                                                  benchmark::Counter::kIsRate);
    state.counters["visible"] = double(raster::countDistinctIds(fb.id));
}

void BM_RenderSphereGrid(benchmark::State& state) {
    renderLoop(state, sphereGrid(int(state.range(0)), 32), 50.0f);
}
BENCHMARK(BM_RenderSphereGrid)->Args({25, 1})->Args({25, 2})->Args({256, 1})->Args({256, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RenderSmallTriangles(benchmark::State& state) {
    renderLoop(state, smallTriangles(int(state.range(0))), 60.0f);
}
BENCHMARK(BM_RenderSmallTriangles)->Args({100000, 1})->Args({100000, 2})->Args({1000000, 2})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
