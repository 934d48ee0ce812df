#!/usr/bin/env bash
# Reruns the README's learning results (rm-1.1 and rm-2.1) with the same
# configs, seeds and evaluation, and prints one line per run:
#   run, wall seconds, training success/return/length, seed-42 evaluation.
# Usage: scripts/reproduce-readme.sh OUT_DIR   (needs target/release/learner:
#   cargo build --release -p buridan-cli)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
LEARNER="$ROOT/target/release/learner"
OUT="${1:?usage: $0 OUT_DIR}"
mkdir -p "$OUT"
cd "$ROOT"

summary() { # run dir -> "success return length wall"
  python3 - "$1/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"train success {100*s['success_rate']:.0f} %, return {s['episode_return_mean']:.2f}, "
      f"length {s['episode_len_mean']:.1f}, {s['env_steps']} steps in {s['wall_seconds']:.0f} s")
PY
}
evaluate() { # run dir, map, agents, starts, mode(sample|greedy)
  local dir="$1" map="$2" agents="$3" starts="$4" mode="$5" flag=""
  [ "$mode" = sample ] && flag="--sample"
  "$LEARNER" eval --map "$map" --agents "$agents" --starts "$starts" --episodes 100 --seed 42 \
    $flag --controller "checkpoint:$dir" --out "$dir/eval-$mode" --json > "$dir/eval-$mode.json"
  python3 - "$dir/eval-$mode.json" "$mode" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d = d[0] if isinstance(d, list) else d
print(f"{sys.argv[2]}: success {d.get('success_rate', d.get('success', 0))*100:.0f} %, "
      f"median steps {d.get('median_steps', d.get('timesteps_median'))}")
PY
}
train() { # name, then learner train arguments
  local name="$1"; shift
  rm -rf "$OUT/$name"
  "$LEARNER" train --quiet "$@" --out "$OUT/$name" 2>> "$OUT/train.log"
  echo "$name: $(summary "$OUT/$name")"
}

# rm-1.1, fixed scenario, 2 agents (learner/configs/RESULTS.md)
train rm11-ppo-ctde --config learner/configs/ppo-ctde-rm-1.1.toml
train rm11-ppo-cte --config learner/configs/ppo-ctde-rm-1.1.toml --mode cte
train rm11-ppo-dte --config learner/configs/ppo-ctde-rm-1.1.toml --mode dte
train rm11-impala-ctde --config learner/configs/impala-ctde-rm-1.1.toml
for r in rm11-ppo-ctde rm11-ppo-cte rm11-ppo-dte rm11-impala-ctde; do
  echo "$r $(evaluate "$OUT/$r" rm-1.1 2 fixed greedy)"
done

# rm-2.1, random starts, 4 agents (README "Results")
train rm21-impala --config learner/configs/impala-ctde-rm-2.1.toml --seed 2 --steps 2000000  # the README's 2M-step figures
train rm21-ppo --config learner/configs/ppo-ctde-rm-2.1.toml --seed 1
for r in rm21-impala rm21-ppo; do
  for m in sample greedy; do
    echo "$r $(evaluate "$OUT/$r" rm-2.1 4 random $m)"
  done
done
