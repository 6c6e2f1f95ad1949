#!/usr/bin/env bash
# Fuzzes the PTM decoder for a bounded time (default 120 s) with libFuzzer (clang), seeded with
# the committed golden files and a few fresh encodings. Usage: scripts/fuzz-ptm.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-120}"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j2 --target plx_ptm_fuzz
corpus=build/fuzz/ptm-corpus
mkdir -p "$corpus"
cp tests/golden/ptm/*.ptm "$corpus/"
# The decoder is built with ASan + UBSan and coverage; UBSan reports are fatal.
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
build/fuzz/tests/fuzz/plx_ptm_fuzz -max_total_time="$seconds" -max_len=4096 -timeout=10 \
    -rss_limit_mb=2048 "$corpus"
