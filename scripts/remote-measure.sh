#!/usr/bin/env bash
# Measures a remote session over loopback: `parallax serve` and `parallax client` as separate
# processes on this machine (they share its cores). One JSON line per row: the setting, then the
# client's summary and the server's totals. Tables: docs/remote-results.md.
#
#   scripts/remote-measure.sh [PARALLAX] [SECONDS]
#   ONLY=REGEX scripts/remote-measure.sh ...   # only the rows whose name matches REGEX
set -euo pipefail
B=${1:-build/release/apps/parallax/parallax}
SECONDS_PER_ROW=${2:-10}
FRAMES=$((SECONDS_PER_ROW * 60))
SCENE=office:8

# row NAME "SERVE OPTIONS" "CLIENT OPTIONS" [SERVER NICENESS]
row() {
    local name=$1 serve=$2 client=$3 niceness=${4:-0} out port pid
    [[ -z ${ONLY:-} || $name =~ $ONLY ]] || return 0
    out=$(mktemp)
    nice -n "$niceness" $B serve $SCENE --port 0 --json $serve >"$out" 2>/dev/null &
    pid=$!
    for _ in $(seq 100); do [ -s "$out" ] && break; sleep 0.1; done
    port=$(head -1 "$out" | python3 -c 'import json,sys; print(json.load(sys.stdin)["port"])')
    local c
    c=$($B client ws://127.0.0.1:$port --scene $SCENE --walk $FRAMES --json $client)
    kill -TERM $pid && wait $pid || true
    python3 - "$name" "$serve" "$client" "$niceness" "$c" "$(tail -1 "$out")" <<'PY'
import json, sys
name, serve, client, niceness, c, s = sys.argv[1:]
print(json.dumps({"row": name, "serve": serve, "client": client,
                  "server_niceness": int(niceness), **json.loads(c), "server": json.loads(s)}))
PY
    rm -f "$out"
}

# 1280x720 at 60 degrees: cube faces of 1248 px (720 / tan 30, the display's pixel density).
# --every 100000: the ground truth once (frame 0), so the loop measures the warp alone.
row "rtt0-720p" "--face-size 1248" "--size 1280x720 --every 100000"
row "rtt500-720p" "--face-size 1248 --latency 250" "--size 1280x720 --every 100000"
# The same with the server below the client's priority (nice 10), as on a machine that shares
# its cores between a render server and an interactive client: the display loop goes first.
row "rtt0-720p-nice10" "--face-size 1248" "--size 1280x720 --every 100000" 10
row "rtt500-720p-nice10" "--face-size 1248 --latency 250" "--size 1280x720 --every 100000" 10
# Prediction against none at RTT 100 ms, PSNR on every 4th frame (640x360, 624-px faces).
row "rtt100-velocity" "--face-size 624 --latency 50 --prediction velocity" "--size 640x360 --every 4"
row "rtt100-none" "--face-size 624 --latency 50 --prediction none" "--size 640x360 --every 4"
