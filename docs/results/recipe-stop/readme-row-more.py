#!/usr/bin/env python3
"""The README's "One-way lanes" row's recipe on more seeds, beside the
recipe as it stands: per layout and column, the mean over training seeds
with its 95 % bootstrap interval (20,000 resamples of the seeds, seed 1),
and the difference recipe minus the row's recipe (unpaired: the two
train differently). Run from the repository root:

    python3 docs/results/recipe-stop/readme-row-more.py

Reads readme-row-more-2026-12-07.csv and readme-row-more-rm-3.1-2026-12-08.csv
beside this file (the row's recipe, `readme-row-more.toml`, on the code of
dd1ea6e9 and 990267f2: seed 0 and seeds 10-19, seed-42 protocol), the row's own ten seeds from
../recipe-lstm-imitation-intent/cells.csv (method
ppo-lstm-imitation-intent-ctde, seeds 0-9 on the code of e8debc79) and
the recipe's twenty seeds from layouts-judged-2026-12-07.csv (seeds 0-9),
layouts-judged-more-2026-12-07.csv (rm-2.2 seeds 10-19) and
rm-3.1-more-2026-12-07.csv (rm-3.1 seeds 10-19).
"""
import csv
import random
from pathlib import Path

HERE = Path(__file__).parent
COLUMNS = {"raw": "greedy", "lanes": "lanes", "shield": "shielded", "sampled": "sampled"}


def mean(xs):
    return sum(xs) / len(xs)


def boot(xs, n=20000):
    rng = random.Random(1)
    ms = sorted(mean([rng.choice(xs) for _ in xs]) for _ in range(n))
    return ms[int(0.025 * n)], ms[int(0.975 * n)]


def boot_diff(a, b, n=20000):
    rng = random.Random(1)
    ds = sorted(mean([rng.choice(a) for _ in a]) - mean([rng.choice(b) for _ in b]) for _ in range(n))
    return ds[int(0.025 * n)], ds[int(0.975 * n)]


def cell(xs):
    if not xs:
        return "–"
    lo, hi = boot(xs)
    return f"{mean(xs):.2f} [{lo:.2f}, {hi:.2f}] ({len(xs)})"


def main():
    today = {}
    for name in ["readme-row-more-2026-12-07.csv", "readme-row-more-rm-3.1-2026-12-08.csv"]:
        for r in csv.DictReader(open(HERE / name)):
            for c in COLUMNS:
                today.setdefault((r["layout"], c, int(r["seed"]) >= 10), []).append(float(r[c]))
    row = {}
    for r in csv.DictReader(open(HERE.parent / "recipe-lstm-imitation-intent" / "cells.csv")):
        if r["method"] == "ppo-lstm-imitation-intent-ctde":
            for c, action in COLUMNS.items():
                if r["actions"] == action:
                    row.setdefault((r["layout"], c), []).append(100 * float(r["success_rate"]))
    recipe = {}
    for name in ["layouts-judged-2026-12-07.csv", "layouts-judged-more-2026-12-07.csv", "rm-3.1-more-2026-12-07.csv"]:
        for r in csv.DictReader(open(HERE / name)):
            for c in COLUMNS:
                recipe.setdefault((r["layout"], c), []).append(float(r[c]))
    print("| layout, column | row's recipe, its own seeds 0-9 | row's recipe today, seed 0 | row's recipe today, seeds 10-19 | row's recipe, all | recipe as it stands, 20 seeds | recipe minus row's recipe (all) |")
    print("|---|---|---|---|---|---|---|")
    for layout in ["rm-2.2", "rm-3.1"]:
        for c in COLUMNS:
            own = row.get((layout, c), [])
            zero = today.get((layout, c, False), [])
            more = today.get((layout, c, True), [])
            every = own + zero + more
            now = recipe.get((layout, c), [])
            lo, hi = boot_diff(now, every)
            print(f"| {layout} {c} | {cell(own)} | {cell(zero)} | {cell(more)} | {cell(every)} | {cell(now)} | {mean(now) - mean(every):+.2f} [{lo:+.2f}, {hi:+.2f}] |")

    # Seeds 10-19 of both recipes, paired by seed: training differs from
    # the first update on, but the seed-42 episodes and the seeds are shared.
    def by_seed(names, layout, c):
        out = {}
        for name in names:
            for r in csv.DictReader(open(HERE / name)):
                if r["layout"] == layout and int(r["seed"]) >= 10:
                    out[int(r["seed"])] = float(r[c])
        return out
    print()
    print("| seeds 10-19, paired | row's recipe | recipe as it stands | recipe minus row's recipe, paired |")
    print("|---|---|---|---|")
    for layout, recipe_file in [("rm-2.2", "layouts-judged-more-2026-12-07.csv"), ("rm-3.1", "rm-3.1-more-2026-12-07.csv")]:
        for c in COLUMNS:
            a = by_seed(["readme-row-more-2026-12-07.csv", "readme-row-more-rm-3.1-2026-12-08.csv"], layout, c)
            b = by_seed([recipe_file], layout, c)
            seeds = sorted(set(a) & set(b))
            if not seeds:
                continue
            d = [b[k] - a[k] for k in seeds]
            lo, hi = boot(d)
            print(f"| {layout} {c} | {cell([a[k] for k in seeds])} | {cell([b[k] for k in seeds])} | {mean(d):+.2f} [{lo:+.2f}, {hi:+.2f}] |")


if __name__ == "__main__":
    main()
