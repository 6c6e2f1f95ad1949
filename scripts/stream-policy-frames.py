#!/usr/bin/env python3
"""Frame by frame: one allocation policy's texture PSNR against the others' at each budget.

Reads the policy_frames.csv that `parallax bench stream` writes (policy, budget_bytes, frame,
time_s, psnr_db: every compared frame of every policy walk) and prints a markdown table: for each
budget and each other policy, the frames where POLICY is better by more than --margin dB, worse by
more than it, and level (docs/stream-results.md).

usage: scripts/stream-policy-frames.py out/bench_stream/policy_frames.csv
           [--policy ach-texture] [--margin 0.01]
"""
import argparse
import csv
import sys
from collections import defaultdict


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("--policy", default="ach-texture")
    ap.add_argument("--margin", type=float, default=0.01)
    args = ap.parse_args()
    frames = defaultdict(dict)  # (budget, policy) -> {frame: psnr}
    try:
        with open(args.csv, newline="") as f:
            for row in csv.DictReader(f):
                frames[(int(row["budget_bytes"]), row["policy"])][int(row["frame"])] = float(
                    row["psnr_db"])
    except (OSError, KeyError, ValueError, TypeError) as e:
        sys.exit(f"error: {args.csv}: not a readable policy_frames.csv ({e})")
    budgets = sorted({b for b, _ in frames})
    others = sorted({p for _, p in frames if p != args.policy})
    if not budgets or (budgets[0], args.policy) not in frames:
        sys.exit(f"error: no frames of policy '{args.policy}' in {args.csv}")
    print(f"| budget | against | {args.policy} better | worse | level |")
    print("| --- | --- | ---: | ---: | ---: |")
    for budget in budgets:
        ours = frames[(budget, args.policy)]
        for other in others:
            theirs = frames.get((budget, other), {})
            shared = [k for k in ours if k in theirs]
            better = sum(ours[k] > theirs[k] + args.margin for k in shared)
            worse = sum(ours[k] < theirs[k] - args.margin for k in shared)
            print(f"| {budget / 2**20:g} MiB | {other} | {better} | {worse} | "
                  f"{len(shared) - better - worse} |")


if __name__ == "__main__":
    main()
