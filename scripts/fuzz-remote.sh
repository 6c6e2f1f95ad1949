#!/usr/bin/env bash
# Fuzzes the remote protocol decoder and the reference-view decoder for a bounded time each
# (default 60 s) with libFuzzer (clang), seeded with the committed corpus tests/fuzz/remote-seeds
# (rewritten by PLX_UPDATE_GOLDEN=1 plx_remote_test). Usage: scripts/fuzz-remote.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j2 --target plx_remote_protocol_fuzz plx_remote_view_fuzz
# The decoders are built with ASan + UBSan and coverage; UBSan reports are fatal.
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
for which in protocol view; do
    corpus="build/fuzz/remote-${which}-corpus"
    mkdir -p "$corpus"
    cp tests/fuzz/remote-seeds/"$which"/*.bin "$corpus/"
    build/fuzz/tests/fuzz/plx_remote_${which}_fuzz -max_total_time="$seconds" -max_len=65536 \
        -timeout=10 -rss_limit_mb=2048 "$corpus"
done
