#!/bin/sh
# The POGEMA benchmark's learned row: the recipe trained under
# pogema rules on the reference layouts rm-3.1 and rm-2.2 (never on the
# warehouse), one policy per training seed, then `learner bench pogema` with
# each policy raw (greedy), through the PIBT collision shield, through the
# shield with its progress fallback (patience 16, the study action
# `fallback`), through the fallback with goal settling, and sampled, beside
# PIBT alone; the seeds pool into one row per mode (mean success and its
# 95 % bootstrap interval).
#
# Usage: scripts/pogema/learned-row.sh OUT [TRAIN_SEEDS] [INSTANCE_SEEDS]
#   OUT             output folder: policies/seed-K/, bench/ (resumable: a
#                   trained seed or a finished bench cell is kept)
#   TRAIN_SEEDS     training seeds, default "0 1 2 3 4 5 6 7 8 9"
#   INSTANCE_SEEDS  the benchmark's instance seeds, default 0..127
# Environment: LEARNER (default: learner on PATH), SHARED (default
#   ../shared/pogema), STEPS (default 1000000), AGENTS (default 16),
#   CONFIG (a training config; default: none, i.e. the default recipe —
#   the README's table was measured with the first recipe,
#   learner/configs/recipe-impala-feedforward.toml), MODES (the policy modes
#   benched, default "learned learned-shield learned-fallback learned-settle
#   learned-sampled"; learned-fallback is shield=16, learned-settle
#   shield-settle=16: the fallback with goal settling).
set -eu
out=${1:?usage: learned-row.sh OUT [TRAIN_SEEDS] [INSTANCE_SEEDS]}
train_seeds=${2:-0 1 2 3 4 5 6 7 8 9}
instance_seeds=${3:-0..127}
learner=${LEARNER:-learner}
shared=${SHARED:-../shared/pogema}
steps=${STEPS:-1000000}
agents=${AGENTS:-16}
config=${CONFIG:-}
modes=${MODES:-learned learned-shield learned-fallback learned-settle learned-sampled}
mkdir -p "$out/policies"
for s in $train_seeds; do
  dir="$out/policies/seed-$s"
  if [ -f "$dir/summary.json" ]; then
    echo "seed $s: trained already ($dir)"
    continue
  fi
  start=$(date +%s)
  "$learner" train ${config:+--config "$config"} --rules pogema --maps rm-3.1:1,rm-2.2:1 \
    --agents "$agents" --steps "$steps" --seed "$s" --out "$dir" --quiet
  echo "seed $s: trained in $(( $(date +%s) - start )) s" | tee -a "$out/train-walls.txt"
done
set -- --controller pibt
for mode in $modes; do
  for s in $train_seeds; do
    ckpt="checkpoint:$out/policies/seed-$s"
    case $mode in
      learned) set -- "$@" --controller "learned#$s=$ckpt" ;;
      learned-shield) set -- "$@" --controller "learned-shield#$s=shield:$ckpt" ;;
      learned-fallback) set -- "$@" --controller "learned-fallback#$s=shield=16:$ckpt" ;;
      learned-sampled) set -- "$@" --controller "learned-sampled#$s=sampled:$ckpt" ;;
      learned-settle) set -- "$@" --controller "learned-settle#$s=shield-settle=16:$ckpt" ;;
      *) echo "unknown mode '$mode' (learned, learned-shield, learned-fallback, learned-settle, learned-sampled)" >&2; exit 2 ;;
    esac
  done
done
"$learner" bench pogema --instances "$shared" --seeds "$instance_seeds" --out "$out/bench" "$@"
