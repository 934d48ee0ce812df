#!/usr/bin/env python3
"""The recipe as it stands against the README's "One-way lanes" row, per
layout: raw greedy and `shield-lanes=16`, the mean of each side's 10
seeds (seed-42 protocol) and the difference with its 95 % bootstrap
interval (unpaired: the two recipes train differently; 20,000 resamples,
seed 1). Run from the repository root:

    python3 docs/results/recipe-stop/against-readme.py [MAIN_JOB_CSV ...]

README row: docs/results/recipe-lstm-imitation-intent/cells.csv (method
ppo-lstm-imitation-intent-ctde). Now: rm-2.1 from finalists-2026-12-05.csv
(variant `finalists`) plus any further main-job CSVs given (rows of
variant `recipe`), the other layouts from layouts-finalists-2026-12-05.csv.
"""
import csv
import random
import sys
from pathlib import Path

HERE = Path(__file__).parent
README = HERE.parent / "recipe-lstm-imitation-intent" / "cells.csv"


def boot_diff(a, b, n=20000):
    rng = random.Random(1)
    ds = sorted(
        sum(rng.choice(a) for _ in a) / len(a) - sum(rng.choice(b) for _ in b) / len(b)
        for _ in range(n)
    )
    return ds[int(0.025 * n)], ds[int(0.975 * n)]


def main():
    readme = {}
    for r in csv.DictReader(open(README)):
        if r["method"] == "ppo-lstm-imitation-intent-ctde":
            readme.setdefault((r["layout"], r["actions"]), []).append(100 * float(r["success_rate"]))
    now = {}
    for r in csv.DictReader(open(HERE / "finalists-2026-12-05.csv")):
        if r["variant"] == "finalists":
            for a in ("greedy", "lanes"):
                now.setdefault(("rm-2.1", a), []).append(float(r[a]))
    for extra in sys.argv[1:]:
        for r in csv.DictReader(open(extra)):
            if r["variant"] == "recipe":
                for a in ("greedy", "lanes"):
                    now.setdefault(("rm-2.1", a), []).append(float(r[a]))
    for r in csv.DictReader(open(HERE / "layouts-finalists-2026-12-05.csv")):
        for a in ("greedy", "lanes"):
            now.setdefault((r["layout"], a), []).append(float(r[a]))
    print("layout,actions,now_seeds,now,readme,difference,low,high")
    for layout in ("rm-2.1", "rm-2.1b", "rm-2.2", "rm-3.1"):
        for a in ("lanes", "greedy"):
            x, y = now[(layout, a)], readme[(layout, a)]
            lo, hi = boot_diff(x, y)
            mx, my = sum(x) / len(x), sum(y) / len(y)
            print(f"{layout},{a},{len(x)},{mx:.1f},{my:.1f},{mx - my:+.1f},{lo:+.1f},{hi:+.1f}")


if __name__ == "__main__":
    main()
