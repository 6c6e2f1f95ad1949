#!/usr/bin/env bash
# Builds plx_raster_vs_llvmpipe and measures Parallax's software rasterizer against Mesa llvmpipe
# (2 threads each, 1280x720, default scene list), with the machine load before and after.
# Results go to out/raster-peer/: table.txt, results.csv, uptime.txt
# (plx_raster_vs_llvmpipe --json prints the same rows as JSON).
# Usage: scripts/bench-raster-peer.sh [extra plx_raster_vs_llvmpipe options, e.g. --frames 30]
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset release >/dev/null
cmake --build --preset release -j2 --target plx_raster_vs_llvmpipe
bench=build/release/libs/gl/plx_raster_vs_llvmpipe
outdir=out/raster-peer
mkdir -p "$outdir"
{ echo "before: $(uptime)"; } > "$outdir/uptime.txt"
"$bench" --csv "$outdir/results.csv" "$@" | tee "$outdir/table.txt"
{ echo "after:  $(uptime)"; } >> "$outdir/uptime.txt"
cat "$outdir/uptime.txt"
