#!/usr/bin/env bash
# End-to-end demo of the compose cluster, for real: a learner and 2 actor
# containers on a private network train rm-1.1 (2 agents, fixed starts, PPO
# CTDE, 200k env steps, clip 0.2, entropy 0.05). Once the learner has made >= KILL_AFTER_UPDATES
# updates, ONE actor container is killed (docker kill, SIGKILL); training must
# still complete on the other. Then the learner must exit 0 and its
# summary.json (bind-mounted out dir) must show episode_return_mean >= MIN_RETURN
# (3 = both agents reach their goals). Prints an outcome block, tears the
# cluster down (docker-compose down -v) and exits non-zero on any failure.
#
# Needs the images: run deploy/build-images.sh first (or BUILD=1 here).
#
# Environment (defaults in brackets):
#   STEPS [200000]  LEARNER_ARGS ["--set ppo.clip=0.2 --set ppo.entropy_coeff=0.05"]  ACTORS [2]
#   KILL_AFTER_UPDATES [5]   MIN_RETURN [2.9]   TIMEOUT [1800] seconds for the run
#   KEEP_OUT=1      keep the out dir (metrics.csv, checkpoints, summary.json, curves)
#   BUILD=1         run deploy/build-images.sh first
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEPLOY="$ROOT/deploy"

export MAP=rm-1.1 AGENTS=2 STARTS=fixed ALGO=ppo MODE=ctde
export STEPS="${STEPS:-200000}"
# Entropy 0.05 on top of clip 0.2: with the default 0.001 some runs settle in
# the "never move, never collide" optimum (return -2.0, success 0) within the
# first ~8 updates and never leave it, whether actors are killed or not
# (embedded runs with 2x16 envs: seeds 4 and 5 of 0-5; distributed: 1 run of
# 10). With 0.05: 16 of 16 seeds embedded and 6 of 6 demo runs reached
# reward 3. See deploy/README.md.
export LEARNER_ARGS="${LEARNER_ARGS:---set ppo.clip=0.2 --set ppo.entropy_coeff=0.05}"
export TAG="${TAG:-dev}" IMAGE_PREFIX="${IMAGE_PREFIX:-buridan}"
export RUST_LOG="${RUST_LOG:-info}"
# Ephemeral loopback host ports: several demos (or a dev cluster) can run at once.
export GRPC_PORT="" METRICS_PORT=""
ACTORS="${ACTORS:-2}"
KILL_AFTER_UPDATES="${KILL_AFTER_UPDATES:-5}"
MIN_RETURN="${MIN_RETURN:-2.9}"
TIMEOUT="${TIMEOUT:-1800}"

PROJECT="buridan-demo-$(date +%Y%m%d%H%M%S)-$$"
OUT_DIR="$(mktemp -d "${TMPDIR:-/tmp}/buridan-demo-out.XXXXXX")"
export OUT_DIR
COMPOSE=(docker-compose -p "$PROJECT" -f "$DEPLOY/docker-compose.yml")

say() { printf '[%5ss] %s\n' "$SECONDS" "$*" >&2; }
fail() { printf 'compose-demo: FAILED: %s\n' "$*" >&2; exit 1; }

cleanup() {
    local rc=$?
    if [[ $rc -ne 0 ]]; then
        echo "---- learner log (last 40 lines) ----" >&2
        "${COMPOSE[@]}" logs --no-color --tail=40 learner >&2 2>/dev/null || true
        echo "---- actor logs (last 15 lines each) ----" >&2
        "${COMPOSE[@]}" logs --no-color --tail=15 actor >&2 2>/dev/null || true
    fi
    if [[ "${KEEP_OUT:-0}" == 1 ]]; then
        "${COMPOSE[@]}" logs --no-color > "$OUT_DIR/compose.log" 2>&1 || true
    fi
    say "tearing down: docker-compose -p $PROJECT down -v"
    "${COMPOSE[@]}" down -v --remove-orphans >/dev/null 2>&1 || true
    if [[ "${KEEP_OUT:-0}" == 1 ]]; then
        say "out dir kept: $OUT_DIR"
    else
        rm -rf "$OUT_DIR"
    fi
    exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM

command -v docker-compose >/dev/null || fail "docker-compose not found"
command -v python3 >/dev/null || fail "python3 not found (reads metrics.csv and summary.json)"
if [[ "${BUILD:-0}" == 1 ]]; then
    "$DEPLOY/build-images.sh"
fi
for b in learner actor; do
    docker image inspect "$IMAGE_PREFIX/$b:$TAG" >/dev/null 2>&1 \
        || fail "image $IMAGE_PREFIX/$b:$TAG missing: run deploy/build-images.sh (or BUILD=1 $0)"
done

# The containers run as uid 65532; the bind-mounted out dir must be theirs.
if [[ "$(id -u)" == 0 ]]; then
    chown 65532:65532 "$OUT_DIR"
else
    export BURIDAN_UID="$(id -u)" BURIDAN_GID="$(id -g)"
fi

# Columns of metrics.csv by name: rows, and the last row's update/env_steps/return.
csv_progress() {
    python3 - "$OUT_DIR/metrics.csv" <<'PY'
import csv, sys
try:
    rows = list(csv.DictReader(open(sys.argv[1])))
except FileNotFoundError:
    rows = []
if not rows:
    print("0 0 0 nan")
else:
    r = rows[-1]
    print(len(rows), r.get("update", "?"), r.get("env_steps", "?"), r.get("episode_return_mean", "?"))
PY
}

say "project $PROJECT: learner + $ACTORS actors, $MAP ${AGENTS} agents $STARTS $ALGO/$MODE, $STEPS steps, $LEARNER_ARGS"
say "out dir (bind mount /data): $OUT_DIR"
"${COMPOSE[@]}" up -d --scale actor="$ACTORS" learner actor
learner_cid="$("${COMPOSE[@]}" ps -q learner)"
mapfile -t actor_cids < <("${COMPOSE[@]}" ps -q actor)
[[ -n "$learner_cid" && ${#actor_cids[@]} -eq $ACTORS ]] \
    || fail "expected 1 learner and $ACTORS actor containers, got: learner='$learner_cid' actors=${#actor_cids[@]}"
cname() { docker inspect -f '{{.Name}}' "$1" | sed 's#^/##'; }
say "learner: $(cname "$learner_cid"); actors: $(for c in "${actor_cids[@]}"; do printf '%s ' "$(cname "$c")"; done)"
network="$(docker inspect -f '{{range $k, $v := .NetworkSettings.Networks}}{{$k}}{{end}}' "$learner_cid")"
say "private network: $network"

# 1. Wait until the learner has made KILL_AFTER_UPDATES updates.
deadline=$((SECONDS + TIMEOUT))
while :; do
    read -r rows update steps ret < <(csv_progress)
    (( rows >= KILL_AFTER_UPDATES )) && break
    state="$(docker inspect -f '{{.State.Status}}' "$learner_cid")"
    [[ "$state" == running ]] || fail "learner is $state before $KILL_AFTER_UPDATES updates"
    (( SECONDS < deadline )) || fail "no $KILL_AFTER_UPDATES updates within ${TIMEOUT}s"
    sleep 0.5
done
say "learner progress: update $update, $steps env steps, return $ret"

# Prometheus endpoint through the ephemeral host port, if curl is here.
metrics_port="$("${COMPOSE[@]}" port learner 9000 2>/dev/null | sed 's/.*://')"
if [[ -n "$metrics_port" ]] && command -v curl >/dev/null; then
    say "GET /metrics on 127.0.0.1:$metrics_port (learner:9000):"
    curl -fsS "http://127.0.0.1:$metrics_port/metrics" | grep -v '^#' | grep -E 'buridan' | head -8 | sed 's/^/        /' >&2 || say "(no buridan_* series yet)"
fi

# 2. Kill one actor.
victim="${actor_cids[0]}"
victim_name="$(cname "$victim")"
survivor="${actor_cids[1]:-}"
kill_t=$SECONDS
kill_update=$update
kill_steps=$steps
kill_ret=$ret
kill_clock="$(date -u +%H:%M:%S.%3N)"
say "docker kill $victim_name (SIGKILL) at $kill_clock UTC: update $update, $steps env steps, return $ret"
docker kill "$victim" >/dev/null

# 3. Training must complete: the learner exits 0 by itself.
say "waiting for the learner to finish $STEPS env steps..."
while [[ "$(docker inspect -f '{{.State.Status}}' "$learner_cid")" == running ]]; do
    (( SECONDS < deadline )) || fail "learner still running after ${TIMEOUT}s"
    sleep 2
done
learner_exit="$(docker inspect -f '{{.State.ExitCode}}' "$learner_cid")"
learner_restarts="$(docker inspect -f '{{.RestartCount}}' "$learner_cid")"
[[ "$learner_exit" == 0 ]] || fail "learner exited with status $learner_exit"
[[ "$learner_restarts" == 0 ]] || fail "learner was restarted $learner_restarts time(s)"
say "learner exited 0"

# The surviving actor(s) should exit 0 once the learner finished the run.
survivor_report=""
for c in "${actor_cids[@]:1}"; do
    for _ in $(seq 1 30); do
        [[ "$(docker inspect -f '{{.State.Status}}' "$c")" == running ]] || break
        sleep 1
    done
    st="$(docker inspect -f '{{.State.Status}} exit={{.State.ExitCode}} restarts={{.RestartCount}}' "$c")"
    survivor_report+="$(cname "$c"): $st; "
done
victim_state="$(docker inspect -f '{{.State.Status}} exit={{.State.ExitCode}} restarts={{.RestartCount}}' "$victim")"
# What the learner logged about the killed actor (its name is its container's
# host name, the short container id).
victim_host="$(docker inspect -f '{{.Config.Hostname}}' "$victim")"
victim_log="$(docker logs "$learner_cid" 2>&1 | grep -F "$victim_host" | sed -E 's/^[0-9-]+T([0-9:]+\.[0-9]{3})[0-9]*Z +/\1 /' | cut -c1-150 || true)"
last_line="$(docker logs "${survivor:-$victim}" 2>&1 | grep 'run finished' | tail -1 || true)"

# 4. The result.
summary="$OUT_DIR/summary.json"
[[ -s "$summary" ]] || fail "no summary.json in $OUT_DIR"
read -r env_steps wall ret success updates < <(python3 - "$summary" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(s["env_steps"], f'{s["wall_seconds"]:.1f}', f'{s["episode_return_mean"]:.3f}',
      f'{s["success_rate"]:.3f}', s.get("updates", "?"))
PY
)
# First row of metrics.csv whose 100-episode mean return reached MIN_RETURN.
reached="$(python3 - "$OUT_DIR/metrics.csv" "$MIN_RETURN" <<'PY'
import csv, sys
for r in csv.DictReader(open(sys.argv[1])):
    if float(r["episode_return_mean"]) >= float(sys.argv[2]):
        print(f'update {r["update"]}, {r["env_steps"]} env steps, {float(r["wall_seconds"]):.1f} s')
        break
else:
    print("never")
PY
)"
ok="$(python3 -c "import sys; print(int(float(sys.argv[1]) >= float(sys.argv[2])))" "$ret" "$MIN_RETURN")"

cat <<OUT

==================== Buridan compose demo: outcome ====================
date           $(date -u +%Y-%m-%dT%H:%M:%SZ)
cluster        1 learner + $ACTORS actors (docker-compose project $PROJECT, network $network)
run            $MAP, $AGENTS agents, $STARTS starts, $ALGO/$MODE, $STEPS steps, $LEARNER_ARGS
killed         $victim_name (docker kill, SIGKILL) at $kill_clock UTC, ${kill_t}s after start;
               learner then at update $kill_update / $kill_steps env steps, return $kill_ret
killed actor   $victim_state
learner saw    $(sed '2,$s/^/               /' <<<"${victim_log:-?}")
survivors      ${survivor_report:-none}
survivor said  ${last_line:-?}
learner        exit 0, restarts $learner_restarts
summary.json   env_steps=$env_steps updates=$updates wall_seconds=$wall
               episode_return_mean=$ret success_rate=$success
return >= $MIN_RETURN  first at $reached
verdict        $([[ $ok == 1 ]] && echo "PASS (return >= $MIN_RETURN)" || echo "FAIL (return < $MIN_RETURN)")
=======================================================================
OUT
[[ $ok == 1 ]] || fail "episode_return_mean $ret < $MIN_RETURN"
