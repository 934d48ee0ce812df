#!/usr/bin/env bash
# Keeps a finished `learner study` directory's report in the repository:
# the tables (table.md/csv/json, cells.csv/json), the figures (*.png), the
# resolved plan.json and the experiment.toml it ran, at the top of DEST.
# Study state (per-run summaries, configs, per-episode and per-update
# files) and checkpoints stay in the study directory, outside git: the
# study file reruns them, and `scripts/check-tree-size.py` keeps the
# tracked tree small. Write the study's RESULTS.md (command, seeds, budget,
# the table) beside what this copies.
#
# Usage: scripts/keep-study.sh SRC DEST
set -euo pipefail
SRC="${1:?usage: $0 SRC DEST}"
DEST="${2:?usage: $0 SRC DEST}"
[ -f "$SRC/plan.json" ] || { echo "$SRC is not a study directory (no plan.json)" >&2; exit 1; }
mkdir -p "$DEST"
for f in plan.json experiment.toml table.md table.csv table.json cells.csv cells.json; do
  if [ -f "$SRC/$f" ]; then cp "$SRC/$f" "$DEST/"; fi
done
cp "$SRC"/*.png "$DEST/" 2>/dev/null || true
du -sh "$DEST" | sed 's/^/kept: /'
