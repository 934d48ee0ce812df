#!/usr/bin/env bash
# Keeps a finished (or partial) `learner study` directory in the repository:
# the report (table.*, cells.*, figures, plan.json, experiment.toml) at the
# top of DEST, and under DEST/study/ what the runner needs to resume and
# `learner study report` needs to re-aggregate — each run's summary.json and
# config.toml, each evaluation's summary.json and command.txt. Per-episode
# and per-update files (episodes.csv, metrics.csv, event files) stay behind
# for size, so a report rebuilt from the kept copy has the same tables but
# keeps the figures that need them (learning curves, box plots) as drawn
# from the full directory.
#
# Usage: scripts/keep-study.sh SRC DEST [--policies]
#   --policies also keeps each run's final checkpoint (checkpoints/final),
#   so further evaluations of the same policies need no retraining.
set -euo pipefail
SRC="${1:?usage: $0 SRC DEST [--policies]}"
DEST="${2:?usage: $0 SRC DEST [--policies]}"
POLICIES="${3:-}"
[ -f "$SRC/plan.json" ] || { echo "$SRC is not a study directory (no plan.json)" >&2; exit 1; }
mkdir -p "$DEST/study"
DEST="$(cd "$DEST" && pwd)"
for f in plan.json experiment.toml table.md table.csv table.json cells.csv cells.json; do
  [ -f "$SRC/$f" ] && cp "$SRC/$f" "$DEST/"
done
cp "$SRC"/*.png "$DEST/" 2>/dev/null || true
cp "$SRC/plan.json" "$SRC/experiment.toml" "$DEST/study/"
# Checkpoints carry their own copy of the run's config.toml: those stay
# behind (a checkpoint directory without weights would look resumable).
(cd "$SRC" && find runs evals -path '*/checkpoints' -prune -o \( -name summary.json -o -name config.toml -o -name command.txt \) -print0 2>/dev/null |
  while IFS= read -r -d '' f; do
    mkdir -p "$DEST/study/$(dirname "$f")"
    cp "$f" "$DEST/study/$f"
  done)
if [ "$POLICIES" = "--policies" ]; then
  (cd "$SRC" && find runs -type d -path '*/checkpoints/final' -print0 |
    while IFS= read -r -d '' d; do
      mkdir -p "$DEST/study/$d"
      cp -r "$d/." "$DEST/study/$d/"
    done)
fi
du -sh "$DEST" | sed 's/^/kept: /'
