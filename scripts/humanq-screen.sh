#!/bin/bash
# The arms of the human-Q idealised protocol (docs/notebook/2026-12-05-human-q-idealised-protocol.md):
# LMS + human Q from scratch with idealised tiles, 24 000 steps, one thread each, then CMF-SIM at
# step 24 000 with location seeds 0, 1, 2 (scripts/protocol-arm.sh). H0 is the table's cell
# (fraction 0.1 of the tiles idealised, the quick eye), H1 raises the fraction to 0.5, H2 trains
# on the `large` eye. Arms run one after another; running it again continues (a stopped arm
# resumes from its newest checkpoint, a measured location seed is skipped, an arm kept in
# runs-kept/humanq/ is restored first). Two copies may run at once on disjoint ARMS lists.
#
# Usage: nice -n 10 scripts/humanq-screen.sh SEED   (51 screens; 52 and 53 replicate)
#   ARMS="H0 H1" scripts/humanq-screen.sh 51       only those arms, in order
#   COLORVISION=path/to/colorvision                the binary
# Records: scripts/record-run.sh runs/humanq/ARM-seedS humanq-ARM-seedS \
#          "docs/notebook/2026-12-05-human-q-idealised-protocol.md @ COMMIT"
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
S=${1:?usage: scripts/humanq-screen.sh SEED}
P="$ROOT/scripts/protocol-arm.sh"
R="$ROOT/runs/humanq"
B=${COLORVISION:-$ROOT/target/release/colorvision}
export COLORVISION=$B RAYON_NUM_THREADS=1
# One arm: its preset (the eye) and the share of tiles that are idealised.
arm() {
    local preset fraction
    case "$1" in
        H0) preset=main fraction=0.1 ;;
        H1) preset=main fraction=0.5 ;;
        H2) preset=large fraction=0.1 ;;
        *) echo "humanq-screen.sh: unknown arm $1 (H0, H1 or H2)" >&2; exit 2 ;;
    esac
    "$P" "$R/$1-seed$S" "$S" 24000 "24000" "0 1 2" --preset "$preset" --cones LMSQ \
        --set retina.scenes.tetra.environment=Idealised \
        --set retina.scenes.tetra.fraction="$fraction"
}

mkdir -p "$R"
for a in ${ARMS:-H0 H1 H2}; do
    echo "== humanq-screen: arm $a, seed $S ($(date -u +%FT%TZ))"
    kept="$ROOT/runs-kept/humanq/$a-seed$S"
    if [ -d "$kept" ] && [ ! -d "$R/$a-seed$S" ]; then cp -r "$kept" "$R/$a-seed$S"; fi
    arm "$a"
done
