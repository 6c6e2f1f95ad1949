// The main of the Google Benchmark programs (plx_add_bench): BENCHMARK_MAIN's, after refusing an
// unknown PLX_FORCE_ISA (forced_isa.h).

#include <benchmark/benchmark.h>

#include "forced_isa.h"

int main(int argc, char** argv) {
    if (plx::mains::refuseUnknownForcedIsa(argv[0])) return 2;
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
