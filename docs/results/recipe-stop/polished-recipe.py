#!/usr/bin/env python3
"""The recipe polished by its own shield (2026-12-07, second session;
variant `judged`: the polish judged raw and through the shield, third
session; `judged-d`, the same runs on the fourth session's machine, and
`fast`, their variant with stop.hold=60000 and polish.epochs=5;
`rounds-6x5`, polish.rounds=6 and polish.epochs=5, no wall times):
per variant and column, the mean over the training seeds with its 95 %
bootstrap interval (20,000 resamples of the seeds, seed 1). Run from the
repository root:

    python3 docs/results/recipe-stop/polished-recipe.py

Reads main-job-c-2026-12-07.csv beside this file: one row per variant and
training seed, with the run's env steps, why it stopped, the wall time of
the whole `learner train` command alone on the machine, the kept
finalist's and the polished weights' replays on the 1,000 final held-out
episodes (raw and through `shield-lanes=16`), whether the polish was kept,
and the final checkpoint's success in % on the seed-42 protocol (raw
greedy, `shield-lanes=16`, the PIBT shield, sampled) and on 1,000
development episodes of seed 7 (raw greedy, `shield-lanes=16`). Then the
same for layouts-polished-2026-12-07.csv and layouts-judged-2026-12-07.csv
(the study's runs on the other comparison layouts with the polished and
the judged recipe, seed-42 protocol only), per layout; `judged-20` pools
the judged recipe's rm-2.2 seeds 0-9 with seeds 10-19
(layouts-judged-more-2026-12-07.csv, fifth session) and rm-3.1's seeds
0-9 with seeds 10-19 (rm-3.1-more-2026-12-07.csv, sixth session, which
also has the column `aside`: `shield[patience=16,ordered,lanes,aside]`;
alone as `rm-3.1-more`), `finalists-both` is the fifth session's
reverted variant on rm-3.1 (finalists-both-2026-12-07.csv).
"""
import csv
import random
from pathlib import Path

HERE = Path(__file__).parent
DATA = HERE / "main-job-c-2026-12-07.csv"
LAYOUTS = {
    "polished": [HERE / "layouts-polished-2026-12-07.csv"],
    "judged": [HERE / "layouts-judged-2026-12-07.csv"],
    # The fifth session: rm-2.2 on seeds 10-19 too, pooled with seeds 0-9.
    "judged-20": [
        HERE / "layouts-judged-2026-12-07.csv",
        HERE / "layouts-judged-more-2026-12-07.csv",
        HERE / "rm-3.1-more-2026-12-07.csv",
    ],
    # The sixth session: rm-3.1 on seeds 10-19, also through
    # shield[patience=16,ordered,lanes,aside] (column aside).
    "rm-3.1-more": [HERE / "rm-3.1-more-2026-12-07.csv"],
    # The fifth session's variant (commit 21652945, reverted): finalists
    # ranked by their raw and shielded replays together, rm-3.1.
    "finalists-both": [HERE / "finalists-both-2026-12-07.csv"],
}
N = 20000
COLUMNS = ["command_wall", "raw", "lanes", "shield", "sampled", "dev_raw", "dev_lanes"]


def boot(xs):
    rng = random.Random(1)
    ms = sorted(sum(rng.choice(xs) for _ in xs) / len(xs) for _ in range(N))
    return ms[int(0.025 * N)], ms[int(0.975 * N)]


def main():
    rows = list(csv.DictReader(open(DATA)))
    print("variant,column,seeds,mean,low,high,min,max")
    for variant in dict.fromkeys(r["variant"] for r in rows):
        mine = [r for r in rows if r["variant"] == variant]
        for col in COLUMNS:
            xs = [float(r[col]) for r in mine if r[col]]
            if not xs:
                continue
            lo, hi = boot(xs)
            print(f"{variant},{col},{len(xs)},{sum(xs) / len(xs):.2f},{lo:.2f},{hi:.2f},{min(xs):.1f},{max(xs):.1f}")
        kept = sum(r["polished_kept"] == "True" for r in mine)
        print(f"{variant},polish_kept,{len(mine)},{kept},,,,")
    print("recipe,layout,column,seeds,mean,low,high,min,max")
    for recipe, paths in LAYOUTS.items():
        rows = [r for path in paths for r in csv.DictReader(open(path))]
        for layout in dict.fromkeys(r["layout"] for r in rows):
            mine = [r for r in rows if r["layout"] == layout]
            for col in ["raw", "lanes", "shield", "sampled", "aside"]:
                xs = [float(r[col]) for r in mine if r.get(col)]
                if not xs:
                    continue
                lo, hi = boot(xs)
                print(f"{recipe},{layout},{col},{len(xs)},{sum(xs) / len(xs):.2f},{lo:.2f},{hi:.2f},{min(xs):.1f},{max(xs):.1f}")


if __name__ == "__main__":
    main()
