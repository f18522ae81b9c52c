#!/bin/bash
# The updates A/B of docs/notebook/2026-12-04-updates-ab-protocol.md: a part-4a tetrachromat
# cell that read below the paper's figure at 96 000 updates, trained on to 192 000 in all
# (`colorvision resume DIR --steps N` on a copy of the cell's run folder: the learning rate is
# constant, so the first 96 000 steps are the cell's, bit for bit), then CMF-SIM at 120 000,
# 144 000 and 168 000 (location seed 0) and at 192 000 (location seeds 0, 1, 2), and the learned
# invariants at those steps. Running it again continues (a stopped run resumes from its newest
# checkpoint; a measured reading is skipped; a run kept in runs-kept/fourth-longer/ is restored
# first).
#
# Usage: CELLS="LMSQ-pigeonQ-surfaces-96k" nice -n 10 scripts/fourth-longer.sh
#   COLORVISION=path/to/colorvision     the binary (the cell's own, for a bit-for-bit continuation)
# The cell's run folder must be in runs/fourth-table/CELL (its 96 000-step checkpoint and
# metrics.csv). Records: scripts/record-run.sh runs/fourth-longer/CELL-192k CELL-192k \
#          "docs/notebook/2026-12-04-updates-ab-protocol.md @ COMMIT"
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
B=${COLORVISION:-$ROOT/target/release/colorvision}
export RAYON_NUM_THREADS=1
R="$ROOT/runs/fourth-longer"
TOTAL=192000

longer() { # cell
    local from="$ROOT/runs/fourth-table/$1" dir="$R/$1-192k" kept="$ROOT/runs-kept/fourth-longer/$1-192k"
    echo "== fourth-longer: $1 → $TOTAL ($(date -u +%FT%TZ))"
    if [ -d "$kept" ] && [ ! -d "$dir" ]; then cp -r "$kept" "$dir"; fi
    if [ ! -d "$dir" ]; then
        [ -d "$from/checkpoints/step_00096000" ] && [ -f "$from/metrics.csv" ] || {
            echo "fourth-longer.sh: $from has no 96 000-step checkpoint and metrics.csv" >&2
            exit 1
        }
        rm -rf "$dir.tmp"
        mkdir -p "$dir.tmp/checkpoints"
        for f in config.toml run.json metrics.csv summary.json; do cp "$from/$f" "$dir.tmp/"; done
        cp -r "$from/checkpoints/step_00096000" "$dir.tmp/checkpoints/"
        mv "$dir.tmp" "$dir"
    fi
    # A boost's run.json names the cortex it continued from its own folder
    # (`../LMS-seed31-12k/checkpoints/…`): that folder is linked beside it.
    local origin
    origin=$(sed -n 's/.*"continued_from": *"\.\.\/\([^/"]*\)\/.*/\1/p' "$dir/run.json")
    if [ -n "$origin" ] && [ ! -e "$R/$origin" ]; then
        ln -sfn "../fourth-table/$origin" "$R/$origin"
    fi
    # A boost counts its own steps, after the LMS cortex's 12 000.
    local own=$TOTAL
    case "$1" in LMS-boost-*) own=$((TOTAL - 12000)) ;; esac
    [ -d "$dir/checkpoints/step_00$TOTAL" ] || "$B" resume "$dir" --steps "$own"
    local step loc dest
    for spec in "120000 0" "144000 0" "168000 0" "192000 0" "192000 1" "192000 2"; do
        read -r step loc <<< "$spec"
        dest="$dir/cmf-sim-step$step-loc$loc"
        [ -f "$dest/cmf_sim.json" ] || "$B" cmf-sim --run "$dir" --checkpoint-step "$step" \
            --location-seed "$loc" --out "$dest"
    done
    "$B" convergence --run "$dir" --steps 96000,120000,144000,168000,192000 > /dev/null
    echo "fourth-longer: $dir done"
}

mkdir -p "$R"
for c in ${CELLS:?name the cells: CELLS=\"LMSQ-pigeonQ-surfaces-96k\"}; do
    longer "$c"
done
