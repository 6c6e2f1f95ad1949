#include <benchmark/benchmark.h>

#include <plx/warp/warp.h>

BENCHMARK_MAIN();
