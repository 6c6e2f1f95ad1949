#!/usr/bin/env python3
"""A walkthrough path through every cell of a stream database (Marvie & Bouatouch section 7.1:
"this path passes through all the rooms"): rooms in serpentine order by their hull centres
(rows along z, alternating x), walking at SPEED m/s between centres at eye height, standing
still STOP seconds in each (the static-viewpoint case), looking along the walk.

usage: stream_walk_path.py DB [--fps 30] [--speed 1.2] [--stop 10] > path.json
Prints the pose list that `parallax stream walk --path` reads."""
import argparse
import glob
import json
import math
import os
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("db")
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--speed", type=float, default=1.2)
    ap.add_argument("--stop", type=float, default=10.0)
    ap.add_argument("--eye-height", type=float, default=1.6)
    a = ap.parse_args()
    centres = []
    for f in sorted(glob.glob(os.path.join(a.db, "cells", "c*.json"))):
        hull = json.load(open(f))["hull"]
        centres.append([(lo + hi) / 2 for lo, hi in zip(hull["min"], hull["max"])])
    rows = {}
    for c in centres:
        rows.setdefault(round(c[2], 3), []).append(c)
    order = []
    for i, z in enumerate(sorted(rows)):
        order += sorted(rows[z], key=lambda c: c[0], reverse=i % 2 == 1)
    poses, heading = [], [1.0, 0.0]
    step = a.speed / a.fps

    def pose(x, z):
        eye = [x, a.eye_height, z]
        poses.append({"eye": eye, "target": [x + heading[0] * 5, a.eye_height, z + heading[1] * 5]})

    x, z = order[0][0], order[0][2]
    for c in order:
        dx, dz = c[0] - x, c[2] - z
        dist = math.hypot(dx, dz)
        if dist > 1e-6:
            heading = [dx / dist, dz / dist]
        for k in range(int(dist / step)):
            pose(x + dx * k * step / dist, z + dz * k * step / dist)
        x, z = c[0], c[2]
        for _ in range(int(a.stop * a.fps)):
            pose(x, z)
    json.dump(poses, sys.stdout)


if __name__ == "__main__":
    main()
