#!/usr/bin/env python3
"""PVS against sampling density and face size (Marvie & Bouatouch section 5).

For each scene, runs `parallax stream build SCENE --cells 0-LAST` (part files only: the PVS
stage) at each sampling, and counts the visible cells the densest sampling finds that a sparser
one misses. Prints a markdown table (docs/stream-results.md).

usage: scripts/stream-sampling.py [--parallax build/release/apps/parallax/parallax]
           [--scenes museum:64 office:16] [--samples 8 32 64] [--faces 128 256] [--threads 2]
"""
import argparse
import json
import subprocess
import tempfile
from pathlib import Path


def run(parallax, scene, samples, face, threads, out):
    info = json.loads(subprocess.check_output(
        [parallax, "stream", "build", scene, "--out", str(out), "--cells", "0-0", "--samples", "1",
         "--face-size", "8", "--json", "--threads", str(threads)]))
    last = info["scene_cells"] - 1
    doc = json.loads(subprocess.check_output(
        [parallax, "stream", "build", scene, "--out", str(out), "--cells", f"0-{last}",
         "--samples", str(samples), "--face-size", str(face), "--json", "--threads",
         str(threads)]))
    part = json.loads((out / doc["part"]).read_text())
    pvs = [{c for c, _ in v["seen"]} | {v["cell"]} for v in part["visibility"]]
    return doc, pvs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--parallax", default="build/release/apps/parallax/parallax")
    ap.add_argument("--scenes", nargs="+", default=["museum:64", "office:16"])
    ap.add_argument("--samples", nargs="+", type=int, default=[8, 32, 64])
    ap.add_argument("--faces", nargs="+", type=int, default=[128, 256])
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    print("| scene | samples | face | cells | cells/s | PVS mean | PVS max "
          "| cells missed vs densest (total) | cells with a miss |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        for scene in a.scenes:
            runs = []
            for face in a.faces:
                for s in a.samples:
                    out = Path(tmp) / f"{scene.replace(':', '_')}-{s}-{face}"
                    runs.append((s, face) + run(a.parallax, scene, s, face, a.threads, out))
            ref = max(runs, key=lambda r: (r[0], r[1]))[3]
            for s, face, doc, pvs in runs:
                missed = [len(r - p) for p, r in zip(pvs, ref)]
                print(f"| {scene} | {s} | {face} | {len(pvs)} | {doc['cells_per_s']:.1f} "
                      f"| {doc['pvs_mean']:.2f} | {doc['pvs_max']} | {sum(missed)} "
                      f"| {sum(1 for m in missed if m)} |")


if __name__ == "__main__":
    main()
