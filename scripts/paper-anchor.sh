#!/bin/bash
# The anchor at the authors' scale (docs/notebook/2026-11-28-slow-colour-protocol-2.md, "The
# anchor"): the `paper` preset's eye (256 × 256 cones) and cortex, LMS, natural surface scenes,
# oracle eye motion, seed 0, trained 10 000 steps with a checkpoint every 1 000 on two threads
# (`colorvision train`, run alone); then Neural Scope of the held-out scenes at 1 000, 5 000
# and 10 000 steps (each picture's hue-angle error in its scope.json) and CMF-SIM at 5 000 and
# 10 000 steps with the preset's budget, location seed 0.
#
# Running it again continues: training resumes from its newest checkpoint, and a measurement
# already written is skipped. Each measurement needs only its checkpoint, so they can be taken
# while training goes on (SKIP_TRAIN=1 measures what exists).
#
# Usage: scripts/paper-anchor.sh OUT_DIR [COLORVISION_BINARY]
#   PRESET=tiny STEPS=20 CHECKPOINTS="10 20" checks the script itself on the test eye.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:?usage: scripts/paper-anchor.sh OUT_DIR [COLORVISION_BINARY]}
BIN=${2:-$ROOT/target/release/colorvision}
[ -x "$BIN" ] || { echo "paper-anchor.sh: $BIN: not built (cargo build --release)" >&2; exit 1; }
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-2}
PRESET=${PRESET:-paper}
STEPS=${STEPS:-10000}
read -r -a CKPTS <<< "${CHECKPOINTS:-1000 5000 10000}"
EVERY=${CKPTS[0]}

if [ -z "${SKIP_TRAIN:-}" ] && [ ! -d "$OUT/checkpoints/step_$(printf %08d "$STEPS")" ]; then
    if [ -f "$OUT/config.toml" ]; then
        "$BIN" train --resume --out "$OUT"
    else
        "$BIN" train --preset "$PRESET" --cones LMS --seed 0 --steps "$STEPS" --out "$OUT" \
            --set oracle_motion=true --set "cortex.train.checkpoint_every_steps=$EVERY"
    fi
fi
for step in "${CKPTS[@]}"; do
    [ -d "$OUT/checkpoints/step_$(printf %08d "$step")" ] || continue
    [ -f "$OUT/scope-step$step/scope.json" ] \
        || "$BIN" scope --run "$OUT" --checkpoint-step "$step" --out "$OUT/scope-step$step"
done
for step in "${CKPTS[@]:1}"; do
    [ -d "$OUT/checkpoints/step_$(printf %08d "$step")" ] || continue
    [ -f "$OUT/cmf-sim-step$step-loc0/cmf_sim.json" ] \
        || "$BIN" cmf-sim --run "$OUT" --checkpoint-step "$step" --location-seed 0 \
            --out "$OUT/cmf-sim-step$step-loc0"
done
echo "paper-anchor.sh: $OUT measured at the checkpoints it has"
