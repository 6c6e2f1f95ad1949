#!/usr/bin/env bash
# Bounded libFuzzer runs (clang, ASan + UBSan) of every decoder of untrusted bytes, two at a time
# (CI has 2 cores): SECONDS each (default 60), so the seven targets take 4 x SECONDS of wall time.
# Each starts from its committed seed corpus; a finding fails the run and leaves the input at
# build/fuzz/<target>-crash-*. Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true

# target | binary | seed files | max input bytes | dictionary (or -)
table="
ptm             plx_ptm_fuzz             tests/golden/ptm/*.ptm                   4096  -
remote-protocol plx_remote_protocol_fuzz tests/fuzz/remote-seeds/protocol/*.bin   65536 -
remote-view     plx_remote_view_fuzz     tests/fuzz/remote-seeds/view/*.bin       65536 -
display-json    plx_display_json_fuzz    tests/fuzz/display-json-seeds/*.json     4096  tests/fuzz/display-json.dict
path-json       plx_path_json_fuzz       tests/fuzz/path-json-seeds/*.json        4096  tests/fuzz/path-json.dict
import-wire     plx_import_wire_fuzz     tests/fuzz/import-wire-seeds/*.bin       16384 -
stream-db       plx_stream_db_fuzz       tests/fuzz/stream-db-seeds/*.bin         32768 tests/fuzz/stream-db.dict
"
wanted=("$@")
selected() {
    [ ${#wanted[@]} -eq 0 ] && return 0
    local w
    for w in "${wanted[@]}"; do [ "$w" = "$1" ] && return 0; done
    return 1
}

names=() binaries=()
while read -r name binary seeds maxlen dict; do
    [ -n "$name" ] && selected "$name" || continue
    names+=("$name")
    binaries+=("$binary")
done <<<"$table"
[ ${#names[@]} -gt 0 ] || { echo "fuzz.sh: no such target: ${wanted[*]}" >&2; exit 2; }

cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j2 --target "${binaries[@]}"
# The decoders are built with ASan + UBSan and coverage; UBSan reports are fatal.
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1

# Starts one target in the background; its output goes to build/fuzz/<target>.log.
start() {
    local name=$1 binary=$2 seeds=$3 maxlen=$4 dict=$5
    local corpus="build/fuzz/${name}-corpus"
    mkdir -p "$corpus"
    # shellcheck disable=SC2086  # the seed pattern is a glob
    cp $seeds "$corpus/"
    local args=(-max_total_time="$seconds" -max_len="$maxlen" -timeout=10 -rss_limit_mb=2048
                -artifact_prefix="build/fuzz/${name}-")
    [ "$dict" != - ] && args+=(-dict="$dict")
    "build/fuzz/tests/fuzz/$binary" "${args[@]}" "$corpus" >"build/fuzz/${name}.log" 2>&1 &
    pids+=($!)
    running+=("$name")
}

# Waits for the running pair; prints each target's last status line, or its log's tail.
finish() {
    local i
    for i in "${!pids[@]}"; do
        if wait "${pids[$i]}"; then
            echo "fuzz ${running[$i]}: $(grep -E '^#[0-9]+' "build/fuzz/${running[$i]}.log" | tail -1)"
        else
            echo "fuzz ${running[$i]}: FAILED (build/fuzz/${running[$i]}.log)" >&2
            tail -40 "build/fuzz/${running[$i]}.log" >&2
            failed=1
        fi
    done
    pids=() running=()
}

failed=0 pids=() running=()
while read -r name binary seeds maxlen dict; do
    [ -n "$name" ] && selected "$name" || continue
    start "$name" "$binary" "$seeds" "$maxlen" "$dict"
    [ ${#pids[@]} -eq 2 ] && finish
done <<<"$table"
[ ${#pids[@]} -gt 0 ] && finish
exit "$failed"
