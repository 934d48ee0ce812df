#!/usr/bin/env python3
"""The shield teacher (`[polish] teacher = "shield"`) on the recipe's
rm-2.1 policies, paired with the recipe itself: per variant and
controller, the mean success over the seeds with its 95 % bootstrap
interval, and the paired difference to the recipe with its own
(20,000 resamples of the seeds, seed 1). Run from the repository root:

    python3 docs/results/recipe-stop/shield-teacher.py

Reads shield-teacher-2026-12-07.csv.gz beside this file: one row per
variant, training seed, episode seed (42: the reported 100 episodes; 7:
1,000 development episodes), controller and success in %.
"""
import csv
import gzip
import random
from pathlib import Path

HERE = Path(__file__).parent
DATA = HERE / "shield-teacher-2026-12-07.csv.gz"
N = 20000


def boot(xs):
    rng = random.Random(1)
    ms = sorted(sum(rng.choice(xs) for _ in xs) / len(xs) for _ in range(N))
    return ms[int(0.025 * N)], ms[int(0.975 * N)]


def main():
    cells = {}
    with gzip.open(DATA, "rt") as f:
        for r in csv.DictReader(f):
            key = (r["variant"], r["episodes"], r["controller"])
            cells.setdefault(key, {})[int(r["seed"])] = float(r["success"])
    print("variant,episodes,controller,seeds,mean,low,high,paired_difference,low,high")
    for (variant, episodes, controller), by_seed in sorted(cells.items()):
        seeds = sorted(by_seed)
        xs = [by_seed[s] for s in seeds]
        lo, hi = boot(xs)
        row = f"{variant},{episodes},{controller},{len(xs)},{sum(xs) / len(xs):.2f},{lo:.2f},{hi:.2f}"
        base = cells.get(("recipe", episodes, controller))
        if variant != "recipe" and base and all(s in base for s in seeds):
            ds = [by_seed[s] - base[s] for s in seeds]
            dlo, dhi = boot(ds)
            row += f",{sum(ds) / len(ds):+.2f},{dlo:+.2f},{dhi:+.2f}"
        else:
            row += ",,,"
        print(row)


if __name__ == "__main__":
    main()
