#!/usr/bin/env bash
# The GPU learner's measurements, in one run on a lent GPU machine (issue
# 59's "Must show"): the parity tests, the update bench on the GPU beside
# the CPU, and the default recipe with 14 CPU actor threads trained with
# the GPU learner and with the CPU learner.
#
# Here (no GPU needed):   scripts/gpu-check.sh --pack
#   builds (scripts/build-cuda.sh: the learner, tests and bench) and leaves the stripped,
#   xz-compressed binaries in target/cuda-carry/ (carry that folder).
# There (the device tool runs it from the repository root):
#   scripts/gpu-check.sh --run
#   unpacks target/cuda-carry/, runs everything, writes $OUT (default
#   runs/gpu-check) seven files, as the device tool brings back at most
#   eight: nvidia-smi.txt, parity.txt, bench.txt, train.log (the two runs'
#   last lines), train-{cuda,cpu}.json (their summary.json), and
#   summary.csv (one row per measurement). The runs themselves stay in
#   $SCRATCH (default /tmp/gpu-check).
#
# Environment there: CUDA_LIBS, the folder with libcublas.so.13 & co.
# (default: the PyTorch venv's nvidia/cu13/lib the lent machine has);
# STEPS, each training run's env steps (default 300000).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
carry="$root/target/cuda-carry"

pack() {
  # The cuda learner, its parity tests and the update bench.
  "$root/scripts/build-cuda.sh"
  rm -rf "$carry" && mkdir -p "$carry"
  newest() { ls -t $1 2>/dev/null | grep -v '\.d$' | head -1; }
  strip -o "$carry/learner" "$root/target/cuda/release/learner"
  strip -o "$carry/device-tests" "$(newest "$root/target/cuda/release/deps/device-*")"
  strip -o "$carry/update-bench" "$(newest "$root/target/cuda/release/deps/update-*")"
  xz -T2 -9e "$carry"/*
  du -sh "$carry"/*
}

run() {
  local out="${OUT:-$root/runs/gpu-check}"
  local scratch="${SCRATCH:-/tmp/gpu-check}"
  local libs="${CUDA_LIBS:-/opt/torch/.venv/lib/python3.12/site-packages/nvidia/cu13/lib}"
  mkdir -p "$out" "$scratch" "$carry/bin"
  for f in learner device-tests update-bench; do
    xz -dkc "$carry/$f.xz" > "$carry/bin/$f" && chmod +x "$carry/bin/$f"
  done
  export LD_LIBRARY_PATH="$libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  nvidia-smi > "$out/nvidia-smi.txt" 2>&1 || true
  echo "measurement,device,value,unit" > "$out/summary.csv"
  # 1. Parity: every test, the GPU ones included.
  (cd "$root/learner" && "$carry/bin/device-tests" --include-ignored --nocapture) > "$out/parity.txt" 2>&1 \
    && echo "parity,cuda,pass," >> "$out/summary.csv" || echo "parity,cuda,FAIL," >> "$out/summary.csv"
  # 2. The update bench, CPU and GPU groups in one run.
  (cd "$root/learner" && "$carry/bin/update-bench" --bench --warm-up-time 1 --measurement-time 5) > "$out/bench.txt" 2>&1 || true
  # 3. The default recipe on rm-2.1 with 14 actor threads: GPU learner, then CPU learner.
  for device in cuda cpu; do
    local t0; t0=$(date +%s)
    RUST_BACKTRACE=0 "$carry/bin/learner" train --map rm-2.1 --agents 4 --algo ppo --mode ctde --seed 0 \
      --device "$device" --set num_actors=14 --steps "${STEPS:-300000}" --no-stop --quiet \
      --out "$scratch/train-$device" > "$scratch/train-$device.log" 2>&1 || true
    echo "recipe_wall_seconds,$device,$(( $(date +%s) - t0 )),s" >> "$out/summary.csv"
    { echo "== $device"; tail -20 "$scratch/train-$device.log"; } >> "$out/train.log"
    cp "$scratch/train-$device/summary.json" "$out/train-$device.json" 2>/dev/null || true
    python3 - "$scratch/train-$device/summary.json" "$device" >> "$out/summary.csv" <<'EOF' || true
import json, sys
s = json.load(open(sys.argv[1]))
print(f"recipe_steps_per_s,{sys.argv[2]},{s['steps_per_s']:.0f},env steps/s")
EOF
  done
  cat "$out/summary.csv"
}

case "${1:-}" in
  --pack) pack ;;
  --run) run ;;
  *) echo "usage: scripts/gpu-check.sh --pack | --run" >&2; exit 2 ;;
esac
