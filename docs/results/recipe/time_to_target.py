#!/usr/bin/env python3
"""Time to target of a study's training runs: the wall time until the
training success first reaches 96 % and stays there.

Reads every run's summary.json under a `learner study` directory (its
`time_to_target`: per level, when the 100-episode training success first
reached it and from which update on it stayed there, in env steps and wall
seconds since the run started — the imitation phase included) and prints,
per layout and method, the mean over seeds with a 95 % percentile-bootstrap
interval (2,000 resamples, seed 0) and the range. A run that never held the
level counts as missing and is reported.

    python3 docs/results/recipe/time_to_target.py docs/results/recipe-lstm-imitation-intent/study
    python3 docs/results/recipe/time_to_target.py runs/STUDY 0.9
"""
import json
import random
import statistics
import sys
from pathlib import Path


def bootstrap(values, resamples=2000, seed=0):
    rng = random.Random(seed)
    means = sorted(
        statistics.fmean(rng.choices(values, k=len(values))) for _ in range(resamples)
    )
    return means[int(0.025 * resamples)], means[int(0.975 * resamples) - 1]


def main(study, level=0.96):
    cells = {}
    for summary in sorted(Path(study).glob("runs/*/*/seed-*/summary.json")):
        layout, method = summary.parts[-4], summary.parts[-3]
        runs = cells.setdefault((layout, method), [])
        targets = json.loads(summary.read_text()).get("time_to_target", [])
        t = next((t for t in targets if abs(t["success"] - level) < 1e-9), None)
        runs.append((summary.parent.name, t))
    print(f"| layout | method | runs | first reached {level:.0%}, wall s | held from, wall s | held from, env steps (median) | held within 30 s |")
    print("|---|---|---|---|---|---|---|")
    for (layout, method), runs in sorted(cells.items()):
        first = [t["first"]["wall_seconds"] for _, t in runs if t and t["first"]]
        held = [t["held"]["wall_seconds"] for _, t in runs if t and t["held"]]
        steps = [t["held"]["env_steps"] for _, t in runs if t and t["held"]]
        missing = [name for name, t in runs if not (t and t["held"])]

        def cell(xs):
            if not xs:
                return "–"
            lo, hi = bootstrap(xs)
            return f"{statistics.fmean(xs):.1f} [{lo:.1f}, {hi:.1f}] ({min(xs):.1f}–{max(xs):.1f})"

        note = f"; never held: {', '.join(missing)}" if missing else ""
        within = sum(h <= 30 for h in held)
        print(
            f"| {layout} | {method} | {len(runs)}{note} | {cell(first)} | {cell(held)} | "
            f"{int(statistics.median(steps)) if steps else '–'} | {within} of {len(runs)} |"
        )


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1], float(sys.argv[2]) if len(sys.argv) > 2 else 0.96)
