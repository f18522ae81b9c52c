#!/bin/bash
# The paper's table, measured once at counts fixed in advance
# (docs/notebook/2026-11-28-paper-table-protocol.md): every cell below is a `colorvision run` of
# the `main` preset (the quick eye and cortex in natural surface scenes, oracle eye motion,
# backprop, CMF-SIM over steps and with the full budget at the end), one thread each, two cells
# at a time. A cell that continues another's cortex (gene therapy, boosting) waits for it.
#
# Running it again continues: a finished cell is skipped, a stopped one resumes from its
# checkpoints (`colorvision resume`), and a cell that stopped with an error (logs/CELL.failed)
# is tried again. Ctrl-C (or SIGTERM) stops every cell after its step, with a checkpoint.
# After a trained run ends, its final checkpoint is measured again with the two location seeds
# after its own (RUN/cmf-sim-step<N>-loc<L>) when its verdict is on the border (the protocol's
# rule: the first passing K above 0.9 of the threshold, or the last failing one below 1.1);
# the run's verdict is then the median of the three (`colorvision gather` reads them). A cell
# is finished when its runs are and their border measurements too (no CELL/.measuring).
# The LMS cells are the learning-rules table's backprop runs when LMS_RUNS names that table's
# `seeds` sweep folder (the same settings, the same losses to the last bit): a finished one is
# copied in under the cell's name.
#
# Usage: scripts/paper-table.sh OUT_DIR [COLORVISION_BINARY]
#   JOBS=N   cells at once (default 2)
#   A check of the script itself, not of the science: PRESET=tiny STEPS=20 (every cell on the
#   32-cone test eye, 20 steps); ONLY=REGEX runs only the cells whose names match (and what
#   they continue).
# Then: scripts/record-run.sh OUT_DIR/CELL CELL for each cell (for the baselines cell, each of
# its four run folders), and scripts/readme-tables.sh.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:?usage: scripts/paper-table.sh OUT_DIR [COLORVISION_BINARY]}
BIN=${2:-$ROOT/target/release/colorvision}
[ -x "$BIN" ] || { echo "paper-table.sh: $BIN: not built (cargo build --release)" >&2; exit 1; }
export RAYON_NUM_THREADS=1
PRESET=${PRESET:-main}
mkdir -p "$OUT/logs"
OUT=$(cd "$OUT" && pwd)

HUE="--set retina.scenes.tetra.environment=HueSphere --set retina.scenes.tetra.fraction=0.1"
IDEAL="--set retina.scenes.tetra.environment=Idealised --set retina.scenes.tetra.fraction=0.1"
# cell | cones | seed | steps | the cell it continues (- for none) | extra settings
CELLS="
LMS-surfaces-seed0-12k|LMS|0|12000|-|
MS-surfaces-12k|MS|0|12000|-|
LMS-surfaces-seed1-12k|LMS|1|12000|-|
LMS-surfaces-seed2-12k|LMS|2|12000|-|
L-surfaces-8k|L|0|8000|-|
M-surfaces-8k|M|0|8000|-|
S-surfaces-8k|S|0|8000|-|
LM-surfaces-12k|LM|0|12000|-|
LS-surfaces-12k|LS|0|12000|-|
LMS-lm1-surfaces-12k|LMS,lm=1|0|12000|-|
LMS-lm0.5-surfaces-12k|LMS,lm=0.5|0|12000|-|
LMS-1to1to1-surfaces-12k|iid,L=1,M=1,S=1|0|12000|-|
baselines-surfaces-8k|LMS|0|8000|-|baselines
MS-gene-replace-surfaces-24k|MS+L_replace_M|0|12000|MS-surfaces-12k|
MS-gene-coexpress-surfaces-24k|MS+L_coexpress_M|0|12000|MS-surfaces-12k|
MS-gene-ratio-surfaces-24k|MS+L_ratio_M|0|12000|MS-surfaces-12k|
LMS-boost-pigeonQ-surfaces-24k|LMSQ,Q:506|0|12000|LMS-surfaces-seed0-12k|
LMS-boost-pigeonQ-huesphere-surfaces-24k|LMSQ,Q:506|0|12000|LMS-surfaces-seed0-12k|$HUE
LMS-boost-pigeonQ-idealised-surfaces-24k|LMSQ,Q:506|0|12000|LMS-surfaces-seed0-12k|$IDEAL
LMS-boost-humanQ-surfaces-24k|LMSQ|0|12000|LMS-surfaces-seed0-12k|
LMS-boost-humanQ-huesphere-surfaces-24k|LMSQ|0|12000|LMS-surfaces-seed0-12k|$HUE
LMS-boost-humanQ-idealised-surfaces-24k|LMSQ|0|12000|LMS-surfaces-seed0-12k|$IDEAL
LMSQ-pigeonQ-surfaces-24k|LMSQ,Q:506|0|24000|-|
LMSQ-pigeonQ-huesphere-surfaces-24k|LMSQ,Q:506|0|24000|-|$HUE
LMSQ-pigeonQ-idealised-surfaces-24k|LMSQ,Q:506|0|24000|-|$IDEAL
LMSQ-humanQ-surfaces-24k|LMSQ|0|24000|-|
LMSQ-humanQ-huesphere-surfaces-24k|LMSQ|0|24000|-|$HUE
LMSQ-humanQ-idealised-surfaces-24k|LMSQ|0|24000|-|$IDEAL
"

# A run folder's border measurement, when its verdict is on the border: the final step and the
# two location seeds after the run's own (`cmf_sim.seed`); nothing otherwise, and an error when
# summary.json does not read. An undefined verdict (0: every K tried failed) is on the border
# when its last K failed by less than 1.1. A run whose base test lies on the line where colour
# constancy ends (its final cmf_sim.json's Σ base error / Σ percept energy between 0.9 and 1.1:
# a light's percept changes between two places by nearly its own size) is on the border too,
# whatever its K margins: at another location seed its verdict may be undefined, or defined.
border_measurements() {
    python3 - "$1/summary.json" "$1/cmf_sim.json" <<'EOF'
import json, os, sys
s = json.load(open(sys.argv[1]))
ratios = dict((k, r) for k, r in s["converged_ratio_per_k"])
d = s["dimension"]
last_failing = d - 1 if d else max(ratios, default=0)
near = (d in ratios and ratios[d] > 0.9) or (last_failing in ratios and ratios[last_failing] < 1.1)
if os.path.exists(sys.argv[2]):
    r = json.load(open(sys.argv[2]))
    base = sum(r["base_error"]) / max(sum(r["energy"]), 1e-300)
    near = near or 0.9 < base < 1.1
if near and s.get("dimension_over_steps"):
    own = s["config"]["cmf_sim"]["seed"]
    print(s["steps"], own + 1, own + 2)
EOF
}

# Measures run folder $1 again with other location seeds when its verdict is on the border.
measure_border() {
    local measurements step loc1 loc2 loc
    measurements=$(border_measurements "$1") || return 1
    [ -z "$measurements" ] && return 0
    read -r step loc1 loc2 <<< "$measurements"
    for loc in "$loc1" "$loc2"; do
        local dest="$1/cmf-sim-step$step-loc$loc"
        [ -f "$dest/cmf_sim.json" ] || "$BIN" cmf-sim --run "$1" \
            --location-seed "$loc" --out "$dest" || return 1
    done
}

done_cell() { [ -f "$OUT/$1/.finished" ]; }
failed() { [ -f "$OUT/logs/$1.failed" ]; }

# Holds CELL for this worker: a lock folder, made once (stale locks are cleared at the start).
take() { mkdir "$OUT/logs/$1.lock" 2>/dev/null; }

run_cell() {
    local name=$1 cones=$2 seed=$3 steps=$4 after=$5 extra=$6 dir="$OUT/$1"
    if [ "$extra" = baselines ]; then
        local resume=(); [ -d "$dir" ] && resume=(--resume)
        "$BIN" experiment baselines --preset "$PRESET" --cones "$cones" --seed "$seed" \
            --steps "${STEPS:-$steps}" --out "$dir" "${resume[@]}" || return $?
        measure_border "$dir/no_demosaicker" || return $?
        measure_border "$dir/trained_on_cone_activations" || return $?
        touch "$dir/.finished"
        return 0
    fi
    if [ -f "$dir/run.json" ] && [ ! -f "$dir/summary.json" ]; then
        "$BIN" resume "$dir" || return $?
    elif [ ! -f "$dir/summary.json" ]; then
        local from=()
        [ "$after" != - ] && from=(--continue-from "$OUT/$after")
        # shellcheck disable=SC2086  # $extra is a list of --set options
        "$BIN" run --preset "$PRESET" --cones "$cones" --seed "$seed" \
            --steps "${STEPS:-$steps}" --out "$dir" "${from[@]}" $extra || return $?
    fi
    measure_border "$dir" || return $?
    touch "$dir/.finished"
}

# Exit statuses of a cell stopped by a signal (Ctrl-C, SIGTERM): not a failure.
stopped_by_signal() { [ "$1" -eq 130 ] || [ "$1" -eq 143 ]; }

worker() {
    while [ ! -f "$OUT/logs/.stop" ]; do
        local left=0 ran=0 status=0
        while IFS='|' read -r name cones seed steps after extra; do
            [ -z "$name" ] && continue
            [ -n "${ONLY:-}" ] && ! [[ $name =~ $ONLY ]] && [[ $ONLY_AFTER != *"|$name|"* ]] && continue
            done_cell "$name" && continue
            failed "$name" && continue
            [ "$after" != - ] && failed "$after" && continue
            left=1
            [ "$after" != - ] && ! done_cell "$after" && continue
            take "$name" || continue
            if done_cell "$name" || failed "$name"; then   # another worker ended it meanwhile
                rm -rf "$OUT/logs/$name.lock"; continue
            fi
            echo "$(date -u +%FT%TZ) worker $1: $name"
            status=0
            run_cell "$name" "$cones" "$seed" "$steps" "$after" "$extra" \
                >> "$OUT/logs/$name.log" 2>&1 || status=$?
            rm -rf "$OUT/logs/$name.lock"
            if [ $status -ne 0 ]; then
                stopped_by_signal $status && return 0
                touch "$OUT/logs/$name.failed"
                echo "$(date -u +%FT%TZ) worker $1: $name stopped (see logs/$name.log)"
            fi
            ran=1
            break
        done <<< "$CELLS"
        [ $left = 0 ] && break
        [ $ran = 0 ] && sleep 60
    done
}

# The LMS cells from the learning-rules table's backprop runs (LMS_RUNS: its seeds sweep).
adopt_lms_runs() {
    local seed src dest
    for seed in 0 1 2; do
        src="$LMS_RUNS/00${seed}_learning_rule=backprop_seed=$seed"
        dest="$OUT/LMS-surfaces-seed$seed-12k"
        [ -f "$src/summary.json" ] && [ ! -e "$dest" ] || continue
        grep -qx 'preset = "main"' "$src/config.toml" && grep -qx "seed = $seed" "$src/config.toml" \
            && grep -qx 'learning_rule = "backprop"' "$src/config.toml" \
            && grep -qx 'steps = 12000' "$src/config.toml" \
            || { echo "paper-table.sh: $src: not the settings of LMS seed $seed" >&2; exit 1; }
        cp -r "$src" "$dest.tmp" && mv "$dest.tmp" "$dest"
        echo "paper-table.sh: LMS-surfaces-seed$seed-12k is $src"
    done
}

# The cells ONLY's cells continue, as |a|b|.
ONLY_AFTER="|$(while IFS='|' read -r n _ _ _ a _; do [[ -n $n && $n =~ ${ONLY:-^$} && $a != - ]] && echo -n "$a|"; done <<< "$CELLS"; true)"
[ -n "${LMS_RUNS:-}" ] && adopt_lms_runs
rm -rf "$OUT"/logs/*.failed "$OUT"/logs/*.lock "$OUT/logs/.stop"   # one call runs at a time
WORKERS=()
for j in $(seq "${JOBS:-2}"); do worker "$j" & WORKERS+=($!); done
stop() {
    touch "$OUT/logs/.stop"
    pkill -TERM -P "$(echo "${WORKERS[@]}" | tr ' ' ,)" 2>/dev/null || true
    pkill -TERM -f "$BIN .*$OUT/" 2>/dev/null || true
    wait
    echo "paper-table.sh: stopped; run it again to continue" >&2
    exit 130
}
trap stop INT TERM
wait
echo "paper-table.sh: every cell of $OUT finished"
