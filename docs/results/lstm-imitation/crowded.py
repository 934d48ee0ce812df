"""Failures of rm-2.1b evaluations on crowded episodes against the rest.

An episode is *crowded* when three or more of its goals lie in one
dead-end aisle of rm-2.1b (rows 0, 3, 6 and 9, from column 2 on).

Usage:
    python3 crowded.py GOALS_DIR EPISODES EVAL_DIR...

GOALS_DIR holds `goals-E.json` for E in 0..EPISODES, each written by
`learner replay --map rm-2.1b --seed S --episodes EPISODES --episode E
--controller random --out GOALS_DIR/goals-E.json` (the controller does
not change the goals); each EVAL_DIR is a `learner eval --seed S
--episodes EPISODES` output with its `episodes.csv`.
"""
import collections
import csv
import json
import sys


def crowded_episodes(goals_dir, episodes):
    crowded = set()
    for e in range(episodes):
        goals = json.load(open(f"{goals_dir}/goals-{e}.json"))["goals"]
        per_aisle = collections.Counter(g["row"] for g in goals if g["col"] >= 2)
        if per_aisle and max(per_aisle.values()) >= 3:
            crowded.add(e)
    return crowded


def main():
    goals_dir, episodes, evals = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    crowded = crowded_episodes(goals_dir, episodes)
    rest = episodes - len(crowded)
    print(f"{len(crowded)} of {episodes} episodes crowded")
    for path in evals:
        rows = list(csv.DictReader(open(f"{path}/episodes.csv")))
        failed = {int(r["episode"]) for r in rows if r["success"] != "true"}
        on_crowded = len(failed & crowded)
        print(
            f"{path}: success {100 * (1 - len(failed) / episodes):.1f} %, "
            f"failures {len(failed)}, on crowded {on_crowded} "
            f"({100 * on_crowded / max(len(crowded), 1):.1f} % of crowded), "
            f"rest {len(failed) - on_crowded} ({100 * (len(failed) - on_crowded) / max(rest, 1):.2f} % of the rest)"
        )


if __name__ == "__main__":
    main()
