#!/usr/bin/env bash
# Measures a render server's memory with many sessions (issue 26's "32 concurrent sessions with
# server memory within a stated bound"): for each client count, a fresh `parallax serve` on a
# free loopback port, that many `parallax client` processes playing the built-in walk at once,
# and the server's peak resident set (VmHWM) read from /proc when they are done. One JSON line
# per row: the server's peak, its idle size, and the clients' sets received and frames/s
# (the ground truth is rendered once, so the clients warp and little else).
# Results: docs/remote-results.md.
#
#   [SIZE=WxH] scripts/remote-sessions-memory.sh [PARALLAX] [SECONDS] [FACE] [COUNTS...]
# SIZE is the clients' display (160x120 by default); a client asks for faces that match it.
set -euo pipefail
B=${1:-build/release/apps/parallax/parallax}
SECONDS_PER_ROW=${2:-8}
FACE=${3:-256}
shift 3 2>/dev/null || shift $#
COUNTS=("$@")
[ ${#COUNTS[@]} -gt 0 ] || COUNTS=(1 32)
SCENE=office:8
FRAMES=$((SECONDS_PER_ROW * 60))

kib() { awk -v k="$1" '$1 == k":" {print $2}' "/proc/$2/status"; }

row() {
    local clients=$1 dir pid port idle
    dir=$(mktemp -d)
    $B serve $SCENE --port 0 --json --face-size "$FACE" --max-sessions 32 --threads 2 \
        >"$dir/serve.json" 2>"$dir/serve.err" &
    pid=$!
    for _ in $(seq 200); do [ -s "$dir/serve.json" ] && break; sleep 0.05; done
    port=$(head -1 "$dir/serve.json" | python3 -c 'import json,sys; print(json.load(sys.stdin)["port"])')
    idle=$(kib VmRSS $pid)
    local pids=()
    for i in $(seq "$clients"); do
        timeout $((SECONDS_PER_ROW + 60)) $B client "ws://127.0.0.1:$port" --scene $SCENE \
            --walk "$FRAMES" --size "${SIZE:-160x120}" --every 100000 --threads 1 --json >"$dir/client-$i.json" \
            2>"$dir/client-$i.err" &
        pids+=($!)
    done
    local failed=0
    for p in "${pids[@]}"; do wait "$p" || failed=$((failed + 1)); done
    local peak
    peak=$(kib VmHWM $pid)
    kill -TERM $pid && wait $pid || true
    python3 - "$clients" "$idle" "$peak" "$failed" "$FACE" "$dir" <<'PY'
import glob, json, statistics, sys
clients, idle, peak, failed, face, folder = sys.argv[1:]
rows = []
for name in sorted(glob.glob(folder + "/client-*.json")):
    try:
        rows.append(json.load(open(name)))
    except ValueError:
        pass
sets = [r.get("references_received", 0) for r in rows]
fps = [r.get("client_fps", 0.0) for r in rows]
print(json.dumps({
    "clients": int(clients), "face_size": int(face), "clients_failed": int(failed),
    "server_idle_mib": round(int(idle) / 1024, 1), "server_peak_mib": round(int(peak) / 1024, 1),
    "sets_received_min": min(sets) if sets else 0, "sets_received_total": sum(sets),
    "client_fps_min": round(min(fps), 1) if fps else 0.0,
    "client_fps_median": round(statistics.median(fps), 1) if fps else 0.0}))
PY
    rm -rf "$dir"
}

for n in "${COUNTS[@]}"; do row "$n"; done
