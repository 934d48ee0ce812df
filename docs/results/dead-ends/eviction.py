#!/usr/bin/env python3
"""The shield's eviction (`evict`) on the dead-end layouts: per layout,
agent count and episode set, each shield's mean success over the
training seeds with its 95 % bootstrap interval, and the paired
difference that `evict` makes to the shield it is added to (20,000
resamples of the seeds, seed 1). Run from the repository root:

    python3 docs/results/dead-ends/eviction.py [EVALS_CSV_GZ]

Input: eviction-2026-12-06.csv.gz, eviction-b-2026-12-06.csv.gz or
eviction-c-2026-12-06.csv.gz (gzipped CSV, columns seed, layout, agents,
controller, episode_seed, episodes, success), as the loops in RESULTS.md
write them; a plain CSV is read as well.
"""
import csv
import gzip
import random
import sys
from pathlib import Path

HERE = Path(__file__).parent
PAIRS = [
    ("shield-ordered=16", "shield[patience=16,ordered,evict]"),
    ("shield-lanes=16", "shield[patience=16,ordered,evict,lanes]"),
    ("shield-lanes=16", "shield[patience=16,ordered,evict,lanes,settle]"),
]


def boot(xs, n=20000):
    rng = random.Random(1)
    ms = sorted(sum(rng.choice(xs) for _ in xs) / len(xs) for _ in range(n))
    return ms[int(0.025 * n)], ms[int(0.975 * n)]


def main():
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "eviction-2026-12-06.csv.gz"
    cells = {}
    opened = gzip.open(path, "rt") if path.suffix == ".gz" else open(path)
    for r in csv.DictReader(opened):
        key = (r["layout"], int(r["agents"]), int(r["episode_seed"]), r["controller"])
        cells.setdefault(key, {})[int(r["seed"])] = float(r["success"])
    print("layout,agents,episode_seed,base,evict,seeds,base_mean,base_low,base_high,"
          "evict_mean,evict_low,evict_high,difference,diff_low,diff_high")
    groups = sorted({k[:3] for k in cells}, key=lambda k: (k[0], k[1], -k[2]))
    for layout, agents, eseed in groups:
        for base, evict in PAIRS:
            b, e = cells.get((layout, agents, eseed, base)), cells.get((layout, agents, eseed, evict))
            if not b or not e:
                continue
            seeds = sorted(set(b) & set(e))
            xb, xe = [b[s] for s in seeds], [e[s] for s in seeds]
            d = [y - x for x, y in zip(xb, xe)]
            mean = lambda xs: sum(xs) / len(xs)
            (bl, bh), (el, eh), (dl, dh) = boot(xb), boot(xe), boot(d)
            print(f"{layout},{agents},{eseed},{base},\"{evict}\",{len(seeds)},{mean(xb):.1f},{bl:.1f},{bh:.1f},"
                  f"{mean(xe):.1f},{el:.1f},{eh:.1f},{mean(d):+.1f},{dl:+.1f},{dh:+.1f}")


if __name__ == "__main__":
    main()
