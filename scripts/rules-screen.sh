#!/bin/bash
# Stage 1 of the learning-rules protocol (docs/notebook/2026-12-02-learning-rules-protocol.md):
# its twelve arms on seed 0, 3 000 steps each, one after another on one thread, each with exactly
# the protocol's command (scripts/protocol-arm.sh: train, then CMF-SIM at step 3 000, location
# seed 0), then each arm's percept against B0's (colorvision percept-alignment). Running it
# again continues: a stopped arm resumes from its newest checkpoint, finished work is skipped.
# Two copies may run at once on different ARMS lists (e.g. ARMS="B0 F1 B1 F2 B2 G0" and
# ARMS="F0 F3 B3 K1 D1 G1"); an arm that ends before B0 has its percept compared with B0's
# when the script runs again. The stage-1 table: scripts/rules-screen-table.py.
#
# Usage: nice -n 10 scripts/rules-screen.sh
#   ARMS="B0 F0" scripts/rules-screen.sh     runs only those arms, in that order
#   COLORVISION=path/to/colorvision           the binary (default target/release/colorvision)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
P="$ROOT/scripts/protocol-arm.sh"
R="$ROOT/runs/rules-screen"
B=${COLORVISION:-$ROOT/target/release/colorvision}
export COLORVISION=$B RAYON_NUM_THREADS=1
# shellcheck source=rules-arms.sh
. "$ROOT/scripts/rules-arms.sh"

arm() {
    arm_options "$1" || exit 2
    "$P" "$R/$1" 0 3000 "3000" "0" --preset main ${OPTS[@]+"${OPTS[@]}"}
}

# An arm stopped or finished on another machine continues from its kept copy
# (runs-kept/rules-screen/, in the repository; scripts/keep-run.sh makes one).
restore() {
    local kept="$ROOT/runs-kept/rules-screen/$1"
    if [ -d "$kept" ] && [ ! -d "$R/$1" ]; then cp -r "$kept" "$R/$1"; fi
}

mkdir -p "$R"
restore B0   # the percepts of every arm are compared with B0's
for a in ${ARMS:-B0 F0 F1 B1 F2 B2 F3 B3 K1 D1 G0 G1}; do
    echo "== rules-screen: arm $a ($(date -u +%FT%TZ))"
    restore "$a"
    arm "$a"
    if [ "$a" != B0 ] && [ -d "$R/B0/checkpoints/step_00003000" ] \
        && [ ! -f "$R/$a/percept-alignment/against-B0.csv" ]; then
        "$B" percept-alignment --run "$R/$a" --against "$R/B0"
    fi
done
