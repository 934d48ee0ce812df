#!/usr/bin/env bash
# Soak of the fleet controller service: N concurrent sessions (default 8)
# for S seconds (default 600), each driven by the example client
# (python/examples/fleet_client.py), lifelong, with execution delays.
# Samples the server's resident memory every 10 s into OUT/memory.csv and
# keeps its Prometheus metrics and every client's summary line.
#
#   scripts/fleet-soak.sh OUT [SESSIONS] [SECONDS]
#
# Needs target/release/fleet-control and a python with grpcio and
# grpcio-tools in $PYTHON (default /tmp/fleet-venv/bin/python). Exits 1 if
# a client fails (robots on one cell or swapping, or an RPC error) or the
# server dies; the memory verdict is read from memory.csv.
set -euo pipefail
out=${1:?usage: scripts/fleet-soak.sh OUT [SESSIONS] [SECONDS]}
sessions=${2:-8}
seconds=${3:-600}
python=${PYTHON:-/tmp/fleet-venv/bin/python}
port=${PORT:-50081}
metrics_port=$((port + 100))
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"

"$root/target/release/fleet-control" --listen "127.0.0.1:$port" \
  --metrics "127.0.0.1:$metrics_port" --max-sessions "$sessions" \
  > "$out/server.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null || true' EXIT
sleep 1

echo "elapsed_s,rss_kib" > "$out/memory.csv"
start=$(date +%s)
sample() { echo "$(( $(date +%s) - start )),$(awk '/VmRSS/ {print $2}' /proc/$server/status)" >> "$out/memory.csv"; }
sample

# On POGEMA's warehouse, half the sessions run lifelong PIBT with 64
# robots and half the shipped learned model through the shield with 16
# robots: both kinds of controller state (planner; policy and shield)
# live at once.
pids=()
for i in $(seq 0 $((sessions - 1))); do
  if (( i % 2 == 0 )); then
    args=(--map-file "$root/mapf/tests/data/pogema/warehouse.map" --rules pogema --robots 64
          --controller lifelong-pibt)
  else
    args=(--map-file "$root/mapf/tests/data/pogema/warehouse.map" --rules pogema --robots 16
          --controller shield-settle=16:checkpoint:model:pogema-warehouse)
  fi
  "$python" "$root/python/examples/fleet_client.py" --server "127.0.0.1:$port" \
    "${args[@]}" --lifelong --delay 0.1 --seed "$i" --steps 100000000 \
    --seconds "$seconds" > "$out/client-$i.txt" 2>&1 &
  pids+=($!)
done

while kill -0 "${pids[0]}" 2>/dev/null; do
  sleep 10
  kill -0 $server || { echo "the server died" >&2; exit 1; }
  sample
done
status=0
for p in "${pids[@]}"; do wait "$p" || status=1; done
sample
curl -s "127.0.0.1:$metrics_port/metrics" > "$out/metrics.txt" || true
kill -TERM $server; wait $server || true
cat "$out"/client-*.txt
exit $status
