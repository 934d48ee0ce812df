#!/usr/bin/env bash
# Long runs of the fuzz targets (the book's "Fuzzed parsers and
# decoders"): every target with CASES inputs (default 1,000,000), in release
# mode with overflow checks on in the crates under test, one target at a
# time; prints per target the inputs run, how many the parser accepted, and
# the wall time. The CI variant is `cargo test` (256 inputs per target).
#
#   scripts/fuzz.sh [CASES] [SUITE...]     SUITE: env proto learner study cli
#
# A failing target prints the smallest input it found and the script exits
# non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
cases="${1:-1000000}"
shift || true
suites=("$@")
[ ${#suites[@]} -eq 0 ] && suites=(env proto learner study cli)

# suite -> package, test file, packages whose arithmetic is checked
run_suite() {
    local package="$1" test="$2"
    shift 2
    local config=()
    for p in "$@"; do
        config+=(--config "profile.release.package.$p.overflow-checks=true")
    done
    echo "== $package --test $test ($cases inputs per target)"
    local log status=0
    log=$(mktemp)
    BURIDAN_FUZZ_CASES="$cases" nice -n 10 cargo test --release --locked -q -p "$package" \
        --test "$test" "${config[@]}" -- --nocapture --test-threads=1 >"$log" 2>&1 || status=$?
    grep -oE "fuzz target .*|test result.*" "$log" || true
    if [ "$status" -ne 0 ]; then
        grep -v -E "^ +[0-9]+: |^ +at " "$log" | tail -60
        failed=1
    fi
    rm -f "$log"
}

failed=0
start=$(date +%s)
for s in "${suites[@]}"; do
    case "$s" in
    env) run_suite buridan-env fuzz buridan-env ;;
    proto) run_suite buridan-proto fuzz buridan-proto buridan-policy buridan-env ;;
    learner) run_suite buridan-learner fuzz_config buridan-learner ;;
    study) run_suite buridan-study fuzz buridan-study ;;
    cli) run_suite buridan-cli fuzz_experiment buridan-cli ;;
    *) echo "unknown suite '$s' (env proto learner study cli)" >&2; exit 2 ;;
    esac
done
echo "all targets: $(( $(date +%s) - start )) s"
exit "$failed"
