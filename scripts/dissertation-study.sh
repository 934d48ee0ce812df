#!/usr/bin/env bash
# The dissertation's whole evaluation program (SPEC §6) in one
# command, on the study files in learner/studies/:
#   1. the phase-1 searches: model 1.1 in all modes, 2.1 and 3.1 (PPO, IMPALA);
#   2. the comparison table: rm-2.1, 2.1b, 2.2, 3.1 x PPO, IMPALA, 10 seeds;
#      and IMPALA again with 10M env steps per run (comparison-impala-10m);
#      the cells the shipped configs now reach with the LSTM warm-started by
#      imitation (comparison-lstm-imitation: PPO on rm-3.1 and rm-2.1b;
#      comparison-impala-lstm-imitation-gentle: IMPALA on rm-2.1b, 2.2, 3.1;
#      comparison-ppo-lstm-imitation-gentle-intent-order: PPO on rm-2.1b
#      without and with the intent feature and with the order feature too,
#      the last the shipped PPO rm-2.1b config; the default recipe,
#      recipe-lstm-imitation-intent, whose rm-3.1 cell is the shipped PPO
#      rm-3.1 config), then each shipped config once more as its header
#      says (scripts/check-configs.sh: the config's own seed and threads);
#   3. scalability on rm-2.1 and rm-3.1 (the comparison's policies with 4..20
#      agents: their run directories are copied, so only evaluations run);
#   4. generalization (trained on rm-3.1 + rm-2.2, evaluated on all four).
# Every step is resumable: rerun with the same OUT after an interruption and
# finished trials, runs and evaluations are skipped. Each step's wall time
# is appended to OUT/wall-times.csv; the total is printed at the end.
#
# Usage: scripts/dissertation-study.sh OUT [--skip-search] [--parallel N]
#   (needs target/release/learner: cargo build --release -p buridan-cli)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
LEARNER="${LEARNER:-$ROOT/target/release/learner}"
OUT="${1:?usage: $0 OUT [--skip-search] [--parallel N]}"
shift
SEARCH=1
PARALLEL=2
while [ $# -gt 0 ]; do
  case "$1" in
    --skip-search) SEARCH=0 ;;
    --parallel) PARALLEL="${2:?--parallel needs a number}"; shift ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
[ -x "$LEARNER" ] || { echo "no learner binary at $LEARNER (cargo build --release -p buridan-cli)" >&2; exit 1; }
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
cd "$ROOT"
TIMES="$OUT/wall-times.csv"
[ -f "$TIMES" ] || echo "step,seconds,finished" > "$TIMES"

# step NAME COMMAND...: runs COMMAND, logs it and records its wall time.
step() {
  local name="$1"; shift
  echo "== $name: $*" >&2
  local start=$SECONDS
  "$@"
  echo "$name,$((SECONDS - start)),$(date -u +%FT%TZ)" >> "$TIMES"
}

# tune FILE: a phase-1 search into OUT/tune/<name>, resumed if it exists.
tune() {
  local name; name="$(basename "$1" .toml)"
  local dir="$OUT/tune/$name" resume=()
  [ -f "$dir/study.json" ] && resume=(--resume)
  step "$name" "$LEARNER" tune "$1" --out "$dir" --parallel "$PARALLEL" "${resume[@]}"
}

# study FILE DIR: a declarative experiment into OUT/DIR.
study() {
  step "$2" "$LEARNER" study "$1" --out "$OUT/$2" --parallel "$PARALLEL" --quiet
}

# reuse LAYOUT DIR: the comparison's runs on LAYOUT, copied into OUT/DIR
# (same configs, seeds, steps and run-directory names), unless already there.
reuse() {
  mkdir -p "$OUT/$2/runs"
  [ -d "$OUT/$2/runs/$1" ] || cp -r "$OUT/comparison/runs/$1" "$OUT/$2/runs/$1"
}

S=learner/studies
if [ "$SEARCH" = 1 ]; then
  for f in $S/tune-ppo-ctde-rm-1.1.toml $S/tune-ppo-cte-rm-1.1.toml $S/tune-ppo-dte-rm-1.1.toml \
           $S/tune-impala-ctde-rm-1.1.toml $S/tune-ppo-ctde-rm-2.1.toml $S/tune-impala-ctde-rm-2.1.toml \
           $S/tune-ppo-ctde-rm-3.1.toml $S/tune-impala-ctde-rm-3.1.toml; do
    tune "$f"
  done
fi
study $S/comparison.toml comparison
study $S/comparison-impala-10m.toml comparison-impala-10m
study $S/comparison-lstm-imitation.toml comparison-lstm-imitation
study $S/comparison-impala-lstm-imitation-gentle.toml comparison-impala-lstm-imitation-gentle
study $S/comparison-ppo-lstm-imitation-gentle-intent-order.toml comparison-ppo-lstm-imitation-gentle-intent-order
study $S/recipe-lstm-imitation-intent.toml recipe-lstm-imitation-intent
reuse rm-2.1 scalability-rm-2.1
study $S/scalability-rm-2.1.toml scalability-rm-2.1
reuse rm-3.1 scalability-rm-3.1
study $S/scalability-rm-3.1.toml scalability-rm-3.1
study $S/generalization.toml generalization
step check-configs env BIN="$(dirname "$LEARNER")" scripts/check-configs.sh "$OUT/check-configs" 1

python3 - "$TIMES" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
total = sum(int(r["seconds"]) for r in rows)
for r in rows:
    print(f"{r['step']:40} {int(r['seconds']):>8} s")
print(f"{'total (every invocation recorded)':40} {total:>8} s = {total / 3600:.1f} h")
PY
