#!/bin/bash
# Stage 2 of the learning-rules protocol (docs/notebook/2026-12-02-learning-rules-protocol.md):
# the one configuration stage 1 declared, ARM, on the fresh seeds 10, 11 and 12 for 12 000 steps
# (`--preset main`), each beside backprop with the same optimiser and loss settings on the same
# seed (scripts/rules-arms.sh: arm_control), then CMF-SIM at 12 000 with location seeds 0, 1, 2
# (scripts/protocol-arm.sh) and each rule run's percept against its seed's backprop run at every
# common checkpoint (`colorvision percept-alignment`). One run after another on one thread;
# running it again continues (a stopped run resumes from its newest checkpoint, finished work
# is skipped; a run kept in runs-kept/rules-confirm/ is restored first). Two copies may run at
# once on different SEEDS lists (e.g. SEEDS="10 11", "12").
#
# Usage: nice -n 10 scripts/rules-confirm.sh ARM
#   SEEDS="10" scripts/rules-confirm.sh F1     only those seeds
#   COLORVISION=path/to/colorvision            the binary (default target/release/colorvision)
# Folders: runs/rules-confirm/ARM-seedS and runs/rules-confirm/CONTROL-seedS.
set -euo pipefail
ARM=${1:?usage: scripts/rules-confirm.sh ARM (the configuration stage 1 declared)}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
P="$ROOT/scripts/protocol-arm.sh"
R="$ROOT/runs/rules-confirm"
B=${COLORVISION:-$ROOT/target/release/colorvision}
export COLORVISION=$B RAYON_NUM_THREADS=1
# shellcheck source=rules-arms.sh
. "$ROOT/scripts/rules-arms.sh"
CONTROL=$(arm_control "$ARM")
[ "$CONTROL" != "$ARM" ] || { echo "rules-confirm.sh: $ARM is a backprop arm, not a rule" >&2; exit 2; }

run() { # arm seed
    arm_options "$1" || exit 2
    "$P" "$R/$1-seed$2" "$2" 12000 "12000" "0 1 2" --preset main ${OPTS[@]+"${OPTS[@]}"}
}

# A run stopped on another machine continues from its kept copy (runs-kept/rules-confirm/, in
# the repository; scripts/keep-run.sh RUN rules-confirm makes one).
restore() {
    local kept="$ROOT/runs-kept/rules-confirm/$1"
    if [ -d "$kept" ] && [ ! -d "$R/$1" ]; then cp -r "$kept" "$R/$1"; fi
}

mkdir -p "$R"
for s in ${SEEDS:-10 11 12}; do
    echo "== rules-confirm: $ARM and $CONTROL, seed $s ($(date -u +%FT%TZ))"
    restore "$CONTROL-seed$s"
    restore "$ARM-seed$s"
    run "$CONTROL" "$s"
    run "$ARM" "$s"
    if [ ! -f "$R/$ARM-seed$s/percept-alignment/against-$CONTROL-seed$s.csv" ]; then
        "$B" percept-alignment --run "$R/$ARM-seed$s" --against "$R/$CONTROL-seed$s"
    fi
done
