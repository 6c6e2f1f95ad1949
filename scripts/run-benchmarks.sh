#!/usr/bin/env bash
# Runs Parallax's benchmarks and experiment drivers, writing results under out/bench/.
# Usage: scripts/run-benchmarks.sh [BUILD_DIR]   (default build/release; build it first)
set -euo pipefail
build=${1:-build/release}
out=out/bench
mkdir -p "$out"
cli="$build/apps/parallax/parallax"

echo "== rasterizer micro-benchmarks"
"$build/libs/raster/plx_raster_bench" --benchmark_out="$out/raster_bench.json" \
    --benchmark_out_format=json
echo "== Parallax against Mesa llvmpipe (2 threads, 1280x720)"
"$build/libs/gl/plx_raster_vs_llvmpipe" --csv "$out/raster_vs_llvmpipe.csv" || \
    echo "(llvmpipe comparison unavailable on this machine)"
echo "== stereo: Heo, Jung, Wohn Table 1 and Fig. 17, Fu, Bao, Peng's table"
"$cli" bench stereo --out "$out/stereo"
"$cli" bench stereo --size 1280x720 --threads 2 --frames 9 --out "$out/stereo_720"
echo "== post-rendering warp: Mark, Bishop, McMillan latency compensation"
"$cli" bench warp --out "$out/warp"
echo "== curved displays: Bimber et al. Table 1 and Figs. 8-10"
"$cli" bench predistort --out "$out/predistort"
echo "== progressive texture maps"
shopt -s nullglob
textures=(../shared/data/textures/sponza/*.jpg ../shared/data/textures/sponza/*.png)
if [ ${#textures[@]} -gt 0 ]; then
    "$build/libs/ptm/plx_ptm_bench" speed "${textures[@]:0:8}"
else
    echo "(../shared/data/textures/sponza absent: skipped)"
fi
echo "== remote rendering: reference-set codec (docs/remote-results.md)"
"$build/libs/remote/plx_remote_bench" --benchmark_out="$out/remote_bench.json" \
    --benchmark_out_format=json
echo "results in $out"
