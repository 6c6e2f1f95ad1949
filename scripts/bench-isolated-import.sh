#!/usr/bin/env bash
# Cost of the isolated import (issue 28): `parallax info` on a ~1M-triangle model, isolated (the
# default) and --no-isolate, runs alternated; prints each median and the ratio, of wall time and
# of CPU time (user + system of the process and its import child: on a loaded machine the wall
# time of two processes stretches with the load, the CPU time does not).
# Usage: scripts/bench-isolated-import.sh [PARALLAX] [RUNS]   (default build/release, 7 runs)
set -euo pipefail
exe=${1:-build/release/apps/parallax/parallax}
runs=${2:-7}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
python3 - "$dir" "$exe" "$runs" <<'PY'
import math, os, statistics, struct, subprocess, sys, time
dir, exe, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
n = 708  # (n-1)^2 * 2 = 999,698 triangles on an n x n grid
z = lambda i, j: 0.05 * math.sin(i * 0.1) * math.cos(j * 0.13)
quads = [(j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1)
         for j in range(n - 1) for i in range(n - 1)]
with open(f"{dir}/grid.ply", "wb") as f:
    f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {n * n}\n"
             "property float x\nproperty float y\nproperty float z\n"
             f"element face {len(quads) * 2}\nproperty list uchar int vertex_indices\n"
             "end_header\n").encode())
    f.write(b"".join(struct.pack("<fff", i / n, j / n, z(i, j))
                     for j in range(n) for i in range(n)))
    f.write(b"".join(struct.pack("<BiiiBiii", 3, a, b, d, 3, a, d, c) for a, b, c, d in quads))
with open(f"{dir}/grid.obj", "w") as f:
    f.write("".join(f"v {i / n:.6f} {j / n:.6f} {z(i, j):.6f}\n"
                    for j in range(n) for i in range(n)))
    f.write("".join(f"f {a+1} {b+1} {d+1}\nf {a+1} {d+1} {c+1}\n" for a, b, c, d in quads))
for model in ("grid.ply", "grid.obj"):
    times = {"isolated": [], "in-process": []}
    cpu = {"isolated": [], "in-process": []}
    for _ in range(runs):
        for name, extra in (("isolated", []), ("in-process", ["--no-isolate"])):
            t, before = time.perf_counter(), os.times()
            subprocess.run([exe, "info", f"{dir}/{model}", *extra], check=True,
                           stdout=subprocess.DEVNULL)
            after = os.times()
            times[name].append(time.perf_counter() - t)
            cpu[name].append(after.children_user - before.children_user +
                             after.children_system - before.children_system)
    iso, inp = statistics.median(times["isolated"]), statistics.median(times["in-process"])
    ciso, cinp = statistics.median(cpu["isolated"]), statistics.median(cpu["in-process"])
    print(f"{model}: wall isolated {iso:.3f} s, in-process {inp:.3f} s, ratio {iso / inp:.3f}; "
          f"cpu isolated {ciso:.3f} s, in-process {cinp:.3f} s, ratio {ciso / cinp:.3f}")
PY
