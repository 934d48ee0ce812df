#!/usr/bin/env python3
"""How much of a hybrid controller's work the planner did.

Reads a `learner study` directory and, for every evaluation of a policy
behind a planner (`rescued`, `lookahead`, `backstop`), prints per layout,
method and actions: success, the share of episodes in which the planner
drove at least once (`rescues` > 0 in episodes.csv: mean, min and max over
seeds), and the median timesteps against a planner's makespans from a
planner CSV (`map,agents,planner,episode,status,makespan,…`, as
docs/results/planners/seed42-4agents-cbs.csv) on the episodes both solve,
pooled over seeds. Writes the same rows as CSV to stdout with --csv.

    python3 docs/results/recipe/planner_share.py runs/comparison-lstm-imitation \\
        docs/results/planners/seed42-4agents-cbs.csv
"""
import csv
import statistics
import sys
from pathlib import Path

HYBRIDS = ("rescued", "lookahead", "backstop", "pace")


def planner_makespans(path):
    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if row["status"] == "ok":
                out[(row["map"], int(row["agents"]), int(row["episode"]))] = int(row["makespan"])
    return out


HEADER = ["layout", "method", "actions", "agents", "seeds", "success_mean",
          "planner_share_mean", "planner_share_min", "planner_share_max",
          "episodes_both_solve", "median_timesteps", "reference_median", "ratio"]


def share_rows(study, planner_csv):
    """The rows of the table (HEADER's columns, formatted) for a study directory."""
    ref = planner_makespans(planner_csv)
    # evals/LAYOUT/METHOD/seed-S/ACTIONS/agents-N/episodes.csv, or with an
    # evaluation layout of its own (a study with `[experiment.eval] layouts`):
    # evals/TRAINED_ON/METHOD/seed-S/LAYOUT/ACTIONS/agents-N/episodes.csv
    cells = {}
    paths = [(p, p.parts[-6:-1]) for p in study.glob("evals/*/*/seed-*/*/agents-*/episodes.csv")]
    for p in study.glob("evals/*/*/seed-*/*/*/agents-*/episodes.csv"):
        method, seed, layout, actions, agents = p.parts[-6:-1]
        paths.append((p, (layout, method, seed, actions, agents)))
    for path, (layout, method, _seed, actions, agents) in sorted(paths):
        if actions not in HYBRIDS:
            continue
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
        if not rows:
            continue
        n = int(agents.removeprefix("agents-"))
        cell = cells.setdefault((layout, method, actions, n), {"success": [], "share": [], "pairs": []})
        cell["success"].append(sum(r["success"] == "true" for r in rows) / len(rows))
        cell["share"].append(sum(r["rescues"] not in ("", "0") for r in rows) / len(rows))
        for r in rows:
            key = (layout, n, int(r["episode"]))
            if r["success"] == "true" and key in ref:
                cell["pairs"].append((int(r["timesteps"]), ref[key]))
    rows = []
    for (layout, method, actions, n), c in sorted(cells.items()):
        pol = [p for p, _ in c["pairs"]]
        ref_m = [r for _, r in c["pairs"]]
        med, rmed = (statistics.median(pol), statistics.median(ref_m)) if pol else (float("nan"),) * 2
        row = [layout, method, actions, n, len(c["share"]),
               f"{100 * statistics.mean(c['success']):.1f}",
               f"{100 * statistics.mean(c['share']):.1f}",
               f"{100 * min(c['share']):.0f}", f"{100 * max(c['share']):.0f}",
               len(pol), med, rmed, f"{med / rmed:.2f}" if pol else "nan"]
        rows.append(row)
    return rows


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    if len(args) != 2:
        sys.exit(__doc__)
    rows = share_rows(Path(args[0]), args[1])
    if "--csv" in argv:
        out = csv.writer(sys.stdout)
        out.writerow(HEADER)
        out.writerows(rows)
    else:
        print("| " + " | ".join(HEADER) + " |")
        print("|" + "---|" * len(HEADER))
        for row in rows:
            print("| " + " | ".join(str(x) for x in row) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
