#!/usr/bin/env bash
# Embedded training against `learner serve` + actor processes on loopback,
# alternating, same config, steps and seeds: env steps/s of each run and
# the ratio gRPC / embedded (the target: IMPALA over gRPC at ≥ 0.9× the
# embedded run). Each pair runs back to back, so both arms see the same
# background load; the ratio is the mean of the per-pair ratios. Usage:
#   cargo build --release -p buridan-cli -p buridan-actor
#   scripts/transport-bench.sh                                   # IMPALA tuned rm-2.1, 2M steps, 3 pairs
#   CONFIG=learner/configs/ppo-ctde-rm-2.1.toml STEPS=400000 scripts/transport-bench.sh
#   ACTOR_ARGS=--raw-obs scripts/transport-bench.sh                # observations uncompressed
#   ACTOR_NICE=10 scripts/transport-bench.sh                       # actors yield the CPU to the learner
# Writes OUT/runs.csv (arm, repeat, env_steps, wall_s, steps_per_s, success).
set -euo pipefail
BIN=${BIN:-target/release}
CONFIG=${CONFIG:-learner/configs/impala-ctde-rm-2.1.toml}
STEPS=${STEPS:-2000000}
REPEATS=${REPEATS:-3}
ACTORS=${ACTORS:-1}
OUT=${OUT:-runs/transport-bench}
PORT=${PORT:-50290}
# Niceness of the actors in both arms (`actor --nice`, and the embedded
# run's actor threads, `actor_nice`; 0: the learner's priority): on a
# machine they share with the learner, niced actors yield the cores to the
# learner's update thread, the run's bottleneck.
ACTOR_NICE=${ACTOR_NICE:-0}
# Extra `actor` flags, split on spaces (e.g. --raw-obs).
read -r -a actor_args <<< "${ACTOR_ARGS:-}"
if [ -e "$OUT/runs.csv" ]; then
  echo "$OUT already holds a benchmark (runs.csv); choose another OUT" >&2
  exit 2
fi
mkdir -p "$OUT"
echo "arm,repeat,env_steps,wall_s,steps_per_s,success" > "$OUT/runs.csv"

# field NAME FILE: a number from a summary.json.
field() { python3 -c 'import json, sys; print(json.load(open(sys.argv[2]))[sys.argv[1]])' "$1" "$2"; }

record() { # ARM REPEAT DIR
  local s="$3/summary.json"
  printf '%s,%s,%s,%s,%s,%s\n' "$1" "$2" "$(field env_steps "$s")" "$(field wall_seconds "$s")" \
    "$(field steps_per_s "$s")" "$(field success_rate "$s")" >> "$OUT/runs.csv"
  printf '%-9s repeat %s: %8.0f env steps/s\n' "$1" "$2" "$(field steps_per_s "$s")"
}

for r in $(seq 0 $((REPEATS - 1))); do
  dir="$OUT/embedded-$r"
  "$BIN/learner" train --config "$CONFIG" --steps "$STEPS" --seed "$r" --out "$dir" --quiet \
    --set "actor_nice=$ACTOR_NICE" \
    2>"$OUT/embedded-$r.log"
  record embedded "$r" "$dir"

  dir="$OUT/grpc-$r"
  "$BIN/learner" serve --config "$CONFIG" --steps "$STEPS" --seed "$r" --out "$dir" \
    --listen "127.0.0.1:$PORT" --quiet 2>"$OUT/grpc-$r.learner.log" &
  learner=$!
  actors=()
  for i in $(seq "$ACTORS"); do
    # Started at once: the actor retries until the learner listens.
    "$BIN/actor" --connect "http://127.0.0.1:$PORT" --name "a$i" --give-up-after 60 --backoff-max 0.1 \
      --nice "$ACTOR_NICE" \
      ${actor_args[@]+"${actor_args[@]}"} \
      2>"$OUT/grpc-$r.actor-$i.log" &
    actors+=($!)
  done
  wait "$learner"
  for a in "${actors[@]}"; do wait "$a" || true; done
  record grpc "$r" "$dir"
done

awk -F, 'NR > 1 { v[$1, $2] = $5; n = ($2 + 1 > n ? $2 + 1 : n) }
  END {
    for (r = 0; r < n; r++) { q = v["grpc", r] / v["embedded", r]; sum += q; e += v["embedded", r]; g += v["grpc", r]
      printf "pair %d: grpc / embedded = %.3f\n", r, q }
    printf "mean env steps/s: embedded %.0f, grpc %.0f; mean ratio %.3f over %d pairs\n", e / n, g / n, sum / n, n
  }' "$OUT/runs.csv" | tee "$OUT/ratio.txt"
