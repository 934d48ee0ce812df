#!/usr/bin/env bash
# Each shipped per-layout config (learner/configs/<algo>-ctde-<layout>.toml),
# checked as a user would: trained exactly as its header says (`learner
# train --config FILE`, the config's own seed, steps and threads), then the
# seed-42 evaluation (100 episodes, 4 agents, random starts and goals, T_max
# 100) with sampled and with greedy actions, beside the dissertation's
# figure (SPEC §6, sampled). Results: docs/results/check-configs/.
#
# Usage: scripts/check-configs.sh OUT [PARALLEL] [CONFIG_NAME ...]
#   PARALLEL  runs at once (default 1; each PPO run uses both cores alone)
#   CONFIG_NAME  e.g. ppo-ctde-rm-2.1b (default: all eight)
# Resumable: a config whose run and evaluations exist is not run again.
# Writes OUT/configs.csv (config, dissertation, sampled, greedy, reached,
# train_seconds) and prints it as a table. Progress: one log line per
# config start and end on stderr; each run's own log in OUT/NAME.log.
set -euo pipefail
OUT="${1:?usage: $0 OUT [PARALLEL] [CONFIG_NAME ...]}"
PARALLEL="${2:-1}"
shift $(( $# >= 2 ? 2 : 1 ))
BIN="${BIN:-target/release}"
[ -x "$BIN/learner" ] || { echo "no $BIN/learner: cargo build --release -p buridan-cli first" >&2; exit 1; }
mkdir -p "$OUT"

# The dissertation's sampled success, seed-42 protocol (SPEC §6).
declare -A FIGURE=(
  [ppo-ctde-rm-2.1]=96 [ppo-ctde-rm-2.1b]=100 [ppo-ctde-rm-2.2]=94 [ppo-ctde-rm-3.1]=97
  [impala-ctde-rm-2.1]=90 [impala-ctde-rm-2.1b]=88 [impala-ctde-rm-2.2]=98 [impala-ctde-rm-3.1]=93
)
NAMES=("$@")
[ ${#NAMES[@]} -gt 0 ] || NAMES=(ppo-ctde-rm-2.1 ppo-ctde-rm-2.1b ppo-ctde-rm-2.2 ppo-ctde-rm-3.1
  impala-ctde-rm-2.1 impala-ctde-rm-2.1b impala-ctde-rm-2.2 impala-ctde-rm-3.1)
for name in "${NAMES[@]}"; do
  [ -n "${FIGURE[$name]:-}" ] || { echo "unknown config '$name' (expected one of: ${!FIGURE[*]})" >&2; exit 2; }
done

# check NAME: train (unless done) and evaluate one config.
check() {
  local name="$1" run="$OUT/$1" layout="${1#*-ctde-}"
  echo "$(date -u +%H:%M:%S) $name: start" >&2
  if [ ! -f "$run/summary.json" ]; then
    "$BIN/learner" train --config "learner/configs/$name.toml" --out "$run" --quiet >"$run.log" 2>&1 ||
      { echo "$name: training failed, see $run.log" >&2; return 1; }
  fi
  local actions flag
  for actions in sampled greedy; do
    flag=""; [ "$actions" = sampled ] && flag=--sample
    [ -f "$run/eval-$actions/summary.json" ] && continue
    "$BIN/learner" eval --map "$layout" --agents 4 --episodes 100 --seed 42 --starts random --t-max 100 \
      --controller "checkpoint:$run" $flag --out "$run/eval-$actions" >>"$run.log" 2>&1 ||
      { echo "$name: evaluation failed, see $run.log" >&2; return 1; }
  done
  echo "$(date -u +%H:%M:%S) $name: done" >&2
}
export -f check
export OUT BIN
printf '%s\n' "${NAMES[@]}" | xargs -P "$PARALLEL" -I{} bash -c 'check "$@"' _ {}

# The table: one row per config, from the run's and evaluations' summaries.
for name in "${NAMES[@]}"; do echo "$name ${FIGURE[$name]}"; done | python3 -c '
import csv, json, sys
out = sys.argv[1]
def summary(path):
    return json.load(open(f"{out}/{path}/summary.json"))
rows = [["config", "dissertation", "sampled", "greedy", "reached", "train_seconds"]]
for line in sys.stdin:
    name, figure = line.split()
    sampled = round(100 * summary(f"{name}/eval-sampled")["success_rate"], 1)
    greedy = round(100 * summary(f"{name}/eval-greedy")["success_rate"], 1)
    reached = "yes" if sampled >= int(figure) else "no"
    rows.append([name, figure, sampled, greedy, reached, round(summary(name)["wall_seconds"])])
rows = [[str(c) for c in r] for r in rows]
csv.writer(open(f"{out}/configs.csv", "w", newline=""), lineterminator="\n").writerows(rows)
widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
for r in rows:
    print("  ".join(c.ljust(w) for c, w in zip(r, widths)))
' "$OUT"
