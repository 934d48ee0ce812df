#!/usr/bin/env python3
"""The shield with and without `aside` on the same policies and episodes.

Plays every (layout, agents, episode seed) cell below through each pair of
controllers with `learner eval` (a cell whose episodes.csv exists is read
back, not run again), then writes `aside.csv` beside this file: success
of each controller and the episodes only one of the pair solves.

    python3 docs/results/stepping-aside/compare.py --learner target/release/learner \
        --runs runs/stepping-aside
"""

import argparse
import csv
import subprocess
from pathlib import Path

HERE = Path(__file__).resolve().parent

# (name, controller without its checkpoint)
PAIRS = [
    (("lanes", "shield-lanes=16"), ("lanes+aside", "shield[patience=16,ordered,lanes,aside]")),
    (("fallback", "shield=16"), ("fallback+aside", "shield[patience=16,aside]")),
]
LAYOUTS = ["rm-2.1", "rm-2.1b", "rm-2.2", "rm-3.1"]
# (agents, episode seed, episodes, pairs)
CELLS = [
    (4, 1000, 1000, PAIRS[:1]),
    (4, 2000, 1000, PAIRS),
    (8, 1000, 1000, PAIRS),
    (16, 1000, 500, PAIRS[:1]),
]


def solved(path):
    with open(path) as f:
        return {int(r["episode"]): r["success"] == "true" for r in csv.DictReader(f)}


def play(learner, runs, layout, agents, seed, episodes, label, controller):
    out = runs / f"{layout}-a{agents}-s{seed}-n{episodes}" / label
    if not (out / "episodes.csv").exists():
        subprocess.run(
            [learner, "eval", "--map", layout, "--agents", str(agents), "--episodes", str(episodes),
             "--seed", str(seed), "--starts", "random", "--t-max", "100",
             "--controller", f"{controller}:checkpoint:model:{layout}", "--out", str(out)],
            check=True, capture_output=True)
    return solved(out / "episodes.csv")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--learner", default="target/release/learner")
    ap.add_argument("--runs", default="runs/stepping-aside", type=Path)
    a = ap.parse_args()
    rows = []
    for agents, seed, episodes, pairs in CELLS:
        for layout in LAYOUTS:
            for (na, ca), (nb, cb) in pairs:
                x = play(a.learner, a.runs, layout, agents, seed, episodes, na, ca)
                y = play(a.learner, a.runs, layout, agents, seed, episodes, nb, cb)
                rows.append({
                    "layout": layout, "agents": agents, "episode_seed": seed, "episodes": episodes,
                    "model": f"model:{layout}", "without": na, "with": nb,
                    "success_without": round(100 * sum(x.values()) / len(x), 1),
                    "success_with": round(100 * sum(y.values()) / len(y), 1),
                    "only_without": sum(x[e] and not y[e] for e in x),
                    "only_with": sum(y[e] and not x[e] for e in x),
                })
                r = rows[-1]
                print(f"{layout:8} {agents:3} agents seed {seed}: {na} {r['success_without']} -> "
                      f"{nb} {r['success_with']} (only {na}: {r['only_without']}, only {nb}: {r['only_with']})")
    with open(HERE / "aside.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
