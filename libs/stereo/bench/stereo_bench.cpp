// Google Benchmark: the second eye from the P-buffer's visible set against a full second eye, on
// office scenes of growing size (the second-eye time should stay flat).
#include <benchmark/benchmark.h>

#include <plx/scene/generators.h>
#include <plx/stereo/stereo.h>

namespace {

using namespace plx;

void BM_Pair(benchmark::State& state, stereo::Method method) {
    scene::Scene s = *scene::generateOffice(int(state.range(0)));
    auto rig = *StereoRig::create(*scene::cameraAt(s, s.viewpoints.front(), 640, 480), {});
    auto r = std::move(stereo::StereoRenderer::create({2})).value();
    stereo::StereoFrame frame;
    stereo::StereoOptions options;
    options.method = method;
    double second = 0;
    for (auto _ : state) second += r->renderPair(s, rig, options, &frame).secondEyeMs;
    state.counters["second_eye_ms"] = second / double(state.iterations());
    state.counters["triangles"] = double(s.triangleCount());
}

void BM_PairFull(benchmark::State& state) { BM_Pair(state, stereo::Method::kFull); }
void BM_PairPBuffer(benchmark::State& state) { BM_Pair(state, stereo::Method::kPBuffer); }
BENCHMARK(BM_PairFull)->Arg(3)->Arg(30)->Arg(280)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PairPBuffer)->Arg(3)->Arg(30)->Arg(280)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
