#!/bin/bash
# One arm × seed of a pre-registered protocol (docs/notebook/*-protocol.md): train with
# `colorvision train` (resuming a stopped run), then CMF-SIM at the listed checkpoints, once
# per location seed, each into DIR/cmf-sim-step<N>-loc<L>/ (skipped when already measured).
# Every process runs on one thread (RAYON_NUM_THREADS=1), as the protocols fix.
#
# Usage: scripts/protocol-arm.sh OUT_DIR SEED STEPS "CKPT_STEPS" "LOC_SEEDS" [train options…]
#   e.g. scripts/protocol-arm.sh runs/A1-seed0 0 12000 "6000 12000" "0 1 2" \
#          --preset quick --cones LMS --config a1.toml
set -euo pipefail
OUT=${1:?OUT_DIR}
SEED=${2:?SEED}
STEPS=${3:?STEPS}
CKPTS=${4:?CKPT_STEPS}
LOCS=${5:?LOC_SEEDS}
shift 5
BIN=${COLORVISION:-$(cd "$(dirname "$0")/.." && pwd)/target/release/colorvision}
export RAYON_NUM_THREADS=1
if [ ! -d "$OUT/checkpoints/step_$(printf %08d "$STEPS")" ]; then
    if [ -f "$OUT/config.toml" ]; then
        "$BIN" train --resume --out "$OUT" --seed "$SEED" --steps "$STEPS" "$@"
    else
        "$BIN" train --out "$OUT" --seed "$SEED" --steps "$STEPS" "$@"
    fi
fi
for step in $CKPTS; do
    for loc in $LOCS; do
        dest="$OUT/cmf-sim-step$step-loc$loc"
        [ -f "$dest/cmf_sim.json" ] && continue
        "$BIN" cmf-sim --run "$OUT" --checkpoint-step "$step" --location-seed "$loc" --out "$dest"
    done
done
echo "protocol-arm: $OUT done"
