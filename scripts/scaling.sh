#!/usr/bin/env bash
# Env steps/s of `learner serve` with 1, 2 and 4 `actor` processes on this
# machine, and the learner's ceiling (agent samples per second of update
# time, from metrics.csv). Usage:
#   cargo build --release -p buridan-cli -p buridan-actor
#   scripts/scaling.sh                          # IMPALA tuned config, 400k steps
#   CONFIG=learner/configs/ppo-ctde-rm-2.1.toml STEPS=200000 scripts/scaling.sh
set -euo pipefail
BIN=${BIN:-target/release}
CONFIG=${CONFIG:-learner/configs/impala-ctde-rm-2.1.toml}
STEPS=${STEPS:-400000}
OUT=${OUT:-runs/scaling}
AGENTS=${AGENTS:-4}
mkdir -p "$OUT"
printf '%-7s %10s %9s %12s %12s %10s\n' actors env_steps wall_s steps_per_s ceiling_sps success
for n in ${ACTORS:-1 2 4}; do
  dir="$OUT/actors-$n"
  rm -rf "$dir"
  port=$((50200 + n))
  "$BIN/learner" serve --config "$CONFIG" --steps "$STEPS" --out "$dir" \
    --listen "127.0.0.1:$port" --quiet 2>"$OUT/actors-$n.learner.log" &
  learner=$!
  sleep 0.5
  actors=()
  for i in $(seq "$n"); do
    "$BIN/actor" --connect "http://127.0.0.1:$port" --name "a$i" --give-up-after 60 \
      2>"$OUT/actors-$n.actor-$i.log" &
    actors+=($!)
  done
  wait "$learner"
  for a in "${actors[@]}"; do wait "$a" || true; done
  steps=$(grep '"env_steps"' "$dir/summary.json" | tr -dc '0-9')
  wall=$(grep '"wall_seconds"' "$dir/summary.json" | sed 's/[^0-9.]//g')
  success=$(grep '"success_rate"' "$dir/summary.json" | sed 's/[^0-9.]//g')
  # Ceiling: agent samples consumed per second of update time.
  ceiling=$(awk -F, -v agents="$AGENTS" '
    NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "env_steps") s = i; if ($i == "learn_seconds") l = i }; next }
    { samples += ($s - prev) * agents; prev = $s; learn += $l }
    END { if (learn > 0) printf "%.0f", samples / learn; else print "-" }' "$dir/metrics.csv")
  printf '%-7s %10s %9.1f %12.0f %12s %10s\n' "$n" "$steps" "$wall" "$(echo "$steps $wall" | awk '{print $1/$2}')" "$ceiling" "$success"
done
