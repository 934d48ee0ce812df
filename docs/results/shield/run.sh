#!/usr/bin/env bash
# Raw vs shielded evaluation of the committed rm-2.1 checkpoints (seed 42,
# 100 episodes, 4/8/12/16 agents). Usage: docs/results/shield/run.sh [LEARNER]
set -euo pipefail
LEARNER=${1:-target/release/learner}
OUT=docs/results/shield
for algo in ppo impala; do
  ckpt=docs/results/$algo-ctde-rm-2.1/checkpoint
  for c in checkpoint shield shield-env; do
    for mode in greedy sample; do
      flag=""; [ "$mode" = sample ] && flag="--sample"
      dir=$OUT/$algo/$c-$mode
      start=$(date +%s.%N)
      nice -n 10 "$LEARNER" eval --map rm-2.1 --agents 4..16:4 --episodes 100 --seed 42 \
        --controller "$( [ "$c" = checkpoint ] && echo "checkpoint:$ckpt" || echo "$c:checkpoint:$ckpt")" $flag --out "$dir" --json > /dev/null
      end=$(date +%s.%N)
      printf '%s\t%s\t%s\t%.1f\n' "$algo" "$c" "$mode" "$(echo "$end - $start" | bc)" >> "$OUT/wall.tsv"
    done
  done
done
