#!/usr/bin/env python3
"""Median timesteps of learned controllers against a planner's, on the
episodes both solve (the target: median timesteps within 10 % of CBS's on
the instances both solve).

Reads a `learner study` directory (its plan.json and each evaluation's
episodes.csv) and prints, per layout, method and action mode, the median
timesteps of the policy and of the planner over the episodes both solved,
pooled over seeds, and their ratio. The planner is one of the study's own
methods, or a planner CSV (`map,agents,planner,episode,status,makespan,…`,
as docs/results/planners/seed42-4agents-cbs.csv) whose makespans stand for
its timesteps.

    python3 docs/results/recipe/timesteps_vs_planner.py runs/recipe cbs
    python3 docs/results/recipe/timesteps_vs_planner.py runs/recipe-lstm-imitation-intent \
        docs/results/planners/seed42-4agents-cbs.csv
"""
import csv
import json
import statistics
import sys
from pathlib import Path


def episodes(path):
    with open(path) as f:
        return {int(r["episode"]): r for r in csv.DictReader(f)}


def planner_csv(path):
    """The planner's name, and per (layout, agents): episode -> a solved row
    with the plan's makespan as its timesteps."""
    name, ref = path, {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            name = r["planner"]
            if r["status"] == "ok":
                ref.setdefault((r["map"], int(r["agents"])), {})[int(r["episode"])] = {
                    "success": "true",
                    "timesteps": r["makespan"],
                }
    return name, ref


def main(study, planner):
    study = Path(study)
    plan = json.loads((study / "plan.json").read_text())
    evals = plan["evals"]
    ref = {}
    if planner.endswith(".csv"):
        planner, ref = planner_csv(planner)
    for e in evals:
        if e["method"] == planner and e["evaluated"]["kind"] == "planner":
            path = study / e["dir"] / "episodes.csv"
            if path.exists():
                ref[(e["layout"], e["agents"])] = episodes(path)
    rows = {}
    for e in evals:
        ev = e["evaluated"]
        if ev["kind"] != "policy" or (e["layout"], e["agents"]) not in ref:
            continue
        path = study / e["dir"] / "episodes.csv"
        if not path.exists():
            continue
        key = (e["layout"], e["agents"], e["method"], ev["actions"])
        mine, theirs = rows.setdefault(key, ([], []))
        for k, r in episodes(path).items():
            p = ref[(e["layout"], e["agents"])].get(k)
            if r["success"] == "true" and p is not None and p["success"] == "true":
                mine.append(int(r["timesteps"]))
                theirs.append(int(p["timesteps"]))
    print(f"| layout | agents | method | actions | episodes both solve (all seeds) | median timesteps | {planner} median | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for (layout, agents, method, actions), (mine, theirs) in sorted(rows.items()):
        if not mine:
            continue
        a, b = statistics.median(mine), statistics.median(theirs)
        print(f"| {layout} | {agents} | {method} | {actions} | {len(mine)} | {a:g} | {b:g} | {a / b:.2f} |")


if __name__ == "__main__":
    main(*sys.argv[1:3])
