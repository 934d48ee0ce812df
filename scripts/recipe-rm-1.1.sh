#!/usr/bin/env bash
# The default recipe on the simplest conflict: rm-1.1, fixed starts,
# 2 agents, 200k env steps, embedded (learner train) or distributed
# (learner serve + one actor --connect). One line per run: the training
# return and success of the last 100 episodes (summary.json), then the mean
# return of the run's final checkpoint over 100 seed-42 episodes, greedy and
# sampled (learner eval).
# usage: scripts/recipe-rm-1.1.sh embedded|served SEED OUTROOT
# (build first: cargo build --release -p buridan-cli --bins
#  && cargo build --release -p buridan-actor --features cli --bin actor)
set -u
mode=$1; seed=$2; root=$3
here=$(cd "$(dirname "$0")/.." && pwd)
L=$here/target/release/learner; A=$here/target/release/actor
out=$root/$mode-s$seed
mkdir -p "$root"; rm -rf "$out"
start=$(date +%s.%N)
args=(--map rm-1.1 --agents 2 --algo ppo --mode ctde --starts fixed --steps 200000 --seed "$seed" --out "$out" --quiet)
if [ "$mode" = embedded ]; then
  "$L" train "${args[@]}" > "$out.log" 2>&1
else
  port=$((52000 + seed))
  "$L" serve "${args[@]}" --listen 127.0.0.1:$port > "$out.log" 2>&1 &
  learner=$!
  sleep 1
  # The actor retries until the learner (imitating first) serves.
  "$A" --connect http://127.0.0.1:$port > "$out.actor.log" 2>&1
  wait $learner
fi
end=$(date +%s.%N)
for how in greedy sampled; do
  flag=(); [ "$how" = sampled ] && flag=(--sample)
  "$L" eval --map rm-1.1 --agents 2 --starts fixed --episodes 100 --seed 42 \
    --controller "checkpoint:$out" "${flag[@]}" --out "$out/eval-$how" > "$out.eval-$how.log" 2>&1
done
python3 - "$out" "$mode" "$seed" "$start" "$end" <<'PY'
import json, sys
out, mode, seed, s, e = sys.argv[1:]
try:
    j = json.load(open(out + "/summary.json"))
    ev = {h: json.load(open(f"{out}/eval-{h}/summary.json"))["reward_mean"] for h in ("greedy", "sampled")}
    print(f"{mode} seed {seed}: return {j['episode_return_mean']:.3f} success {j['success_rate']:.2f} "
          f"steps {j['env_steps']} wall {float(e) - float(s):.0f} s stop {j.get('stop_reason')}; "
          f"final checkpoint return greedy {ev['greedy']:.3f} sampled {ev['sampled']:.3f}")
except Exception as ex:
    print(f"{mode} seed {seed}: no summary ({ex})")
PY
