#!/usr/bin/env python3
"""Mean success over a group of evaluation layouts per training run, then
over runs: mean and 95 % percentile-bootstrap CI (2,000 resamples), from a
study's cells.csv.

    python3 docs/results/recipe-generalization/mean_of_layouts.py docs/results/recipe-generalization/cells.csv
"""
import csv
import random
import statistics
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
policy = [r for r in rows if r["kind"] == "policy"]
ref = ["rm-2.1", "rm-2.1b", "rm-2.2", "rm-3.1"]
unseen = sorted({r["layout"] for r in policy} - set(ref))
print("| layouts | actions | runs | mean success % [95 % CI] |")
print("|---|---|---|---|")
for name, group in [("the four reference layouts", ref), ("the four unseen layouts", unseen)]:
    for act in ["sampled", "greedy", "shielded", "fallback", "ordered", "lanes", "rescued", "backstop", "pace"]:
        per = {}
        for r in policy:
            # Cells not evaluated yet (a partial study) have no success rate.
            if r["actions"] == act and r["layout"] in group and r["success_rate"]:
                per.setdefault(r["seed"], []).append(100 * float(r["success_rate"]))
        vals = [statistics.mean(v) for v in per.values() if len(v) == len(group)]
        if not vals:
            continue
        rng = random.Random(0)
        boots = sorted(statistics.mean(rng.choices(vals, k=len(vals))) for _ in range(2000))
        print(f"| {name} | {act} | {len(vals)} | {statistics.mean(vals):.1f} [{boots[49]:.1f}, {boots[1949]:.1f}] |")
