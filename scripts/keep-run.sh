#!/bin/bash
# Keeps a stopped run in the repository so that it continues on another machine: its settings,
# start, per-step metrics, newest checkpoint and the readings a protocol arm has taken
# (cmf-sim-step*/, percept-alignment/) go to runs-kept/<GROUP>/<NAME>/ (about 3 MB for a
# quick-eye run). `colorvision train --resume --out DIR …` (or `colorvision resume DIR`) on a copy
# of that folder continues the run from the kept checkpoint, bit for bit as if it had never
# stopped (same thread count); scripts/fourth-screen.sh, scripts/fourth-table.sh,
# scripts/fourth-longer.sh, scripts/border-rows.sh, scripts/humanq-screen.sh,
# scripts/rules-screen.sh and scripts/rules-confirm.sh restore their runs from runs-kept/GROUP/
# (fourth, fourth-table, fourth-longer, border, humanq, rules-screen, rules-confirm).
# Usage: scripts/keep-run.sh RUN_DIR GROUP        e.g. scripts/keep-run.sh runs/fourth/A0-seed21 fourth
set -euo pipefail
RUN=${1:?usage: scripts/keep-run.sh RUN_DIR GROUP}
GROUP=${2:?usage: scripts/keep-run.sh RUN_DIR GROUP}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
[ -f "$RUN/config.toml" ] || { echo "keep-run.sh: $RUN: not a run folder (no config.toml)" >&2; exit 1; }
NEWEST=$(ls -d "$RUN"/checkpoints/step_* 2>/dev/null | sort | tail -1)
[ -n "$NEWEST" ] || { echo "keep-run.sh: $RUN: no checkpoint to keep" >&2; exit 1; }
DEST="$ROOT/runs-kept/$GROUP/$(basename "$RUN")"
TMP=$(mktemp -d "$ROOT/runs-kept/.tmp.XXXXXX" 2>/dev/null || { mkdir -p "$ROOT/runs-kept"; mktemp -d "$ROOT/runs-kept/.tmp.XXXXXX"; })
trap 'rm -rf "$TMP"' EXIT
for f in config.toml run.json metrics.csv summary.json cmf_sim.json dimension.svg; do
    [ -f "$RUN/$f" ] && cp "$RUN/$f" "$TMP/"
done
# The checkpoint a continued run started from, named from the run's folder (as runs now write
# it) where an older run named it by its absolute path: the two are kept side by side.
FROM=$(sed -n 's/.*"continued_from": *"\(\/[^"]*\)".*/\1/p' "$TMP/run.json" 2>/dev/null || true)
if [ -n "$FROM" ]; then
    REL=$(realpath -m --relative-to="$RUN" "$FROM" | sed 's/[\\&#]/\\&/g')
    sed -i "s#\"continued_from\": *\"[^\"]*\"#\"continued_from\": \"$REL\"#" "$TMP/run.json"
fi
mkdir "$TMP/checkpoints" && cp -r "$NEWEST" "$TMP/checkpoints/"
for m in "$RUN"/cmf-sim-step* "$RUN"/percept-alignment; do   # a protocol arm's readings so far
    [ -d "$m" ] && cp -r "$m" "$TMP/"
done
rm -rf "$DEST"
mkdir -p "$(dirname "$DEST")"
mv "$TMP" "$DEST"
trap - EXIT
echo "kept $RUN at $(basename "$NEWEST") in ${DEST#$ROOT/}"
