#!/usr/bin/env python3
"""The ablation table of the default recipe, one row per layout and method.

Reads a `learner study` directory after `learner study report` (its
`table.csv`: mean success and 95 % CI per layout, method and actions) and
its evaluations' `episodes.csv` (planner_share.share_rows: the share of
the backstop's and the pace net's episodes the planner drove, and the pace
net's timesteps against a planner's makespans), and prints a Markdown
table: sampled, greedy, shielded, backstop, pace. Cells whose episodes
were not kept (a study resumed from a kept copy) take their planner share
from planner_share.py CSVs named after the planner CSV.

    learner study report runs/recipe-lstm-imitation-ablation
    python3 docs/results/recipe/ablation_table.py runs/recipe-lstm-imitation-ablation \\
        docs/results/planners/seed42-4agents-cbs.csv docs/results/recipe-lstm-imitation/planner-share.csv
"""
import csv
import sys
from pathlib import Path

from planner_share import HEADER, share_rows

ACTIONS = ("sampled", "greedy", "shielded", "backstop", "pace")


def success_cells(study):
    cells = {}
    with open(study / "table.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r["success %"]:
                cells[(r["layout"], r["method"], r["actions"])] = (
                    f"{float(r['success %']):.1f} [{float(r['success %_low']):.1f}, "
                    f"{float(r['success %_high']):.1f}]"
                )
    return cells


def planner_cells(study, planner_csv, kept):
    cells = {}
    for path in kept:
        with open(path, newline="") as f:
            cells.update({(r["layout"], r["method"], r["actions"]): r for r in csv.DictReader(f)})
    for row in share_rows(study, planner_csv):
        r = dict(zip(HEADER, (str(x) for x in row)))
        cells[(r["layout"], r["method"], r["actions"])] = r
    return cells


def main(argv):
    if len(argv) < 2:
        sys.exit(__doc__)
    study = Path(argv[0])
    success = success_cells(study)
    planner = planner_cells(study, argv[1], argv[2:])
    layouts = list(dict.fromkeys(k[0] for k in success))
    methods = list(dict.fromkeys(k[1] for k in success))
    print("| layout | method | sampled | greedy | shielded | backstop (planner drove) "
          "| pace (planner drove; timesteps / CBS) |")
    print("|---|---|---|---|---|---|---|")
    for layout in layouts:
        for method in methods:
            row = [success.get((layout, method, a), "–") for a in ACTIONS]
            if all(x == "–" for x in row):
                continue
            for i, a in ((3, "backstop"), (4, "pace")):
                p = planner.get((layout, method, a))
                if p and row[i] != "–":
                    extra = f"{float(p['planner_share_mean']):.1f} %"
                    if a == "pace" and p["ratio"] != "nan":
                        extra += f"; {p['ratio']}"
                    row[i] += f" ({extra})"
            print(f"| {layout} | {method} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
