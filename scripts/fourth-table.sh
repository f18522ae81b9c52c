#!/bin/bash
# The paper's four tetrachromat rows at 96 000 updates in all
# (docs/notebook/2026-12-04-tetrachromat-rows-protocol.md, parts 4a and 4b: seed 31, a tenth of
# the tiles idealised; docs/notebook/2026-12-05-idealised-share-table-protocol.md, part 5: the
# `…-idealised-half-…` cells, seed 61, half the tiles idealised), one thread, trained with
# `colorvision train` (from scratch 96 000 steps; boosted: the LMS cortex of the cell's seed at
# 12 000 steps continued 84 000 steps, its checkpoints numbered on from 12 000), then CMF-SIM
# at step 96 000 with location seeds 0, 1, 2. Cells run in the protocol's order, one after
# another; running it again continues (a stopped cell resumes from its newest checkpoint, a
# finished cell, a cell recorded in results/ and a measured location seed are skipped; a cell
# kept in runs-kept/fourth-table/ is restored first). Two copies may run at once on
# disjoint CELLS lists; a boost cell waits for its LMS cortex (LMS-seedS-12k) to finish.
#
# Usage: nice -n 10 scripts/fourth-table.sh
#   CELLS="LMSQ-pigeonQ-surfaces-96k …" scripts/fourth-table.sh    only those cells, in order
#   COLORVISION=path/to/colorvision                                the binary
# Records: scripts/record-run.sh runs/fourth-table/CELL CELL \
#          "PROTOCOL PAGE @ COMMIT"
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
R="$ROOT/runs/fourth-table"
B=${COLORVISION:-$ROOT/target/release/colorvision}
export RAYON_NUM_THREADS=1
HUE=(--set retina.scenes.tetra.environment=HueSphere --set retina.scenes.tetra.fraction=0.1)
IDEAL=(--set retina.scenes.tetra.environment=Idealised --set retina.scenes.tetra.fraction=0.1)
HALF=(--set retina.scenes.tetra.environment=Idealised --set retina.scenes.tetra.fraction=0.5)

# The part 4a cells (pigeon Q) first, then part 4b (human Q), as the protocol orders them. Part 5's
# cells run only when named in CELLS (its protocol says when): LMSQ-humanQ-idealised-half-surfaces-96k
# LMS-seed61-12k LMS-boost-humanQ-idealised-half-surfaces-96k LMSQ-pigeonQ-idealised-half-surfaces-96k
# LMS-boost-pigeonQ-idealised-half-surfaces-96k.
ALL="LMSQ-pigeonQ-surfaces-96k LMS-seed31-12k LMS-boost-pigeonQ-surfaces-96k
LMSQ-pigeonQ-huesphere-surfaces-96k LMS-boost-pigeonQ-huesphere-surfaces-96k
LMSQ-pigeonQ-idealised-surfaces-96k LMS-boost-pigeonQ-idealised-surfaces-96k
LMSQ-humanQ-idealised-surfaces-96k LMS-boost-humanQ-idealised-surfaces-96k
LMSQ-humanQ-surfaces-96k LMS-boost-humanQ-surfaces-96k
LMSQ-humanQ-huesphere-surfaces-96k LMS-boost-humanQ-huesphere-surfaces-96k"

# The cell's seed, cones and scene settings: sets SEED, ADULT (the LMS cortex a boost
# continues), CONES and ENV.
cell_settings() {
    case "$1" in
        *idealised-half*|LMS-seed61-*) SEED=61 ;;
        *) SEED=31 ;;
    esac
    ADULT="$R/LMS-seed$SEED-12k"
    case "$1" in
        LMS-seed*) CONES=LMS ;;
        *pigeonQ*) CONES=LMSQ,Q:506 ;;
        *humanQ*) CONES=LMSQ ;;
        *) echo "fourth-table.sh: unknown cell $1" >&2; exit 2 ;;
    esac
    case "$1" in
        *huesphere*) ENV=("${HUE[@]}") ;;
        *idealised-half*) ENV=("${HALF[@]}") ;;
        *idealised*) ENV=("${IDEAL[@]}") ;;
        *) ENV=() ;;
    esac
}

# CMF-SIM of run folder $1 at step 96 000, location seeds 0, 1, 2 (each skipped when done).
read_cell() {
    for loc in 0 1 2; do
        dest="$1/cmf-sim-step96000-loc$loc"
        [ -f "$dest/cmf_sim.json" ] || "$B" cmf-sim --run "$1" --checkpoint-step 96000 \
            --location-seed "$loc" --out "$dest"
    done
}

boost() { # cell
    local dir="$R/$1"
    restore "$(basename "$ADULT")"
    while [ ! -d "$ADULT/checkpoints/step_00012000" ]; do
        echo "fourth-table.sh: $1 waits for $ADULT ($(date -u +%FT%TZ))"; sleep 300
    done
    if [ ! -d "$dir/checkpoints/step_00096000" ]; then
        if [ -f "$dir/metrics.csv" ]; then
            "$B" resume "$dir"
        else
            "$B" train --preset main --cones "$CONES" ${ENV[@]+"${ENV[@]}"} --seed "$SEED" \
                --steps 84000 --continue-from "$ADULT" --out "$dir"
        fi
    fi
    read_cell "$dir"
}

# A cell stopped on another machine continues from its kept copy (runs-kept/fourth-table/, in
# the repository; scripts/keep-run.sh runs/fourth-table/CELL fourth-table makes one).
restore() {
    local kept="$ROOT/runs-kept/fourth-table/$1"
    if [ -d "$kept" ] && [ ! -d "$R/$1" ]; then cp -r "$kept" "$R/$1"; fi
}

cell() {
    echo "== fourth-table: $1 ($(date -u +%FT%TZ))"
    # A recorded cell is done: its kept folder is removed when it is recorded.
    if [ -f "$ROOT/results/$1/record.json" ]; then
        echo "fourth-table.sh: $1 is recorded in results/$1: skipped"
        return
    fi
    restore "$1"
    cell_settings "$1"
    case "$1" in
        LMS-seed*-12k)
            "$ROOT/scripts/protocol-arm.sh" "$R/$1" "$SEED" 12000 "12000" "0" \
                --preset main --cones LMS ;;
        LMS-boost-*) boost "$1" ;;
        LMSQ-*)
            "$ROOT/scripts/protocol-arm.sh" "$R/$1" "$SEED" 96000 "96000" "0 1 2" \
                --preset main --cones "$CONES" ${ENV[@]+"${ENV[@]}"} ;;
    esac
}

mkdir -p "$R"
export COLORVISION=$B
for c in ${CELLS:-$ALL}; do
    cell "$c"
done
