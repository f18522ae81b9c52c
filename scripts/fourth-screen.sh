#!/bin/bash
# The screen of the fourth-dimension protocol (docs/notebook/2026-12-02-fourth-dimension-protocol.md),
# its arms in the protocol's order — the controls first (A0, A0i, C1b, C1c, C2), then
# A3, A4 (with A4-LMS), C1a, A2a, A2b, the `large` eye's A1, and the hue-rule arms A5c, A5 — one after another on one thread, each with exactly the
# protocol's command (scripts/protocol-arm.sh). Running it again continues: a stopped arm
# resumes from its newest checkpoint, a finished arm and a measured location seed are skipped.
# Two copies may run at once on different ARMS lists (e.g. ARMS="A0 C1b C2" and ARMS="A0i C1c").
#
# Usage: scripts/fourth-screen.sh [SEED]          (SEED: 21 for the screen, 22 or 23 to replicate)
#   ARMS="A0 A0i" scripts/fourth-screen.sh 21      runs only those arms, in that order
#   COLORVISION=path/to/colorvision                the binary (default target/release/colorvision)
# Records: scripts/record-run.sh runs/fourth/ARM-seedS fourth-ARM-seedS \
#          "docs/notebook/2026-12-02-fourth-dimension-protocol.md @ 8095818"
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
S=${1:-21}
P="$ROOT/scripts/protocol-arm.sh"
R="$ROOT/runs/fourth"
B=${COLORVISION:-$ROOT/target/release/colorvision}
export COLORVISION=$B RAYON_NUM_THREADS=1
TETRA=(--preset main --cones LMSQ,Q:506)
IDEAL=(--set retina.scenes.tetra.environment=Idealised --set retina.scenes.tetra.fraction=0.1)
HUE=(--set retina.scenes.tetra.environment=HueSphere --set retina.scenes.tetra.fraction=0.5)
# The paper's hue-sphere cell, and with it the max-chroma hue rule
# (docs/notebook/2026-12-03-hue-rule-protocol.md).
HUE10=(--set retina.scenes.tetra.environment=HueSphere --set retina.scenes.tetra.fraction=0.1)
MAXCHROMA=(--set retina.scenes.tetra.hue_rule=max_chroma)

continue_to() { # folder of a finished run, copy, steps: the A2 arms
    [ -d "$2/checkpoints/step_$(printf %08d "$3")" ] && return 0
    if [ ! -d "$2" ] && [ ! -f "$1/metrics.csv" ]; then
        echo "fourth-screen.sh: $(basename "$2") continues $1, which is not here with its" \
            "per-step log: run its arm first (e.g. ARMS=\"A0 A2a A2b\"; training is" \
            "deterministic, so it is the same run)" >&2
        exit 1
    fi
    [ -d "$2" ] || cp -r "$1" "$2"
    "$B" resume "$2" --steps "$3"
}

arm() {
    case "$1" in
        A0)  "$P" "$R/A0-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" ;;
        A1)  "$P" "$R/A1-seed$S" "$S" 24000 "24000" "0 1 2" --preset large --cones LMSQ,Q:506 ;;
        A0i) "$P" "$R/A0i-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" "${IDEAL[@]}" ;;
        A3)  "$P" "$R/A3-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" "${HUE[@]}" ;;
        A5c) "$P" "$R/A5c-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" "${HUE10[@]}" ;;
        A5)  "$P" "$R/A5-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" "${HUE10[@]}" \
                 "${MAXCHROMA[@]}" ;;
        C1a) "$P" "$R/C1a-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" \
                 --set retina.scenes.q_from_lms=before_balance ;;
        C1b) "$P" "$R/C1b-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" \
                 --set retina.scenes.q_from_lms=after_balance ;;
        C1c) "$P" "$R/C1c-seed$S" "$S" 24000 "24000" "0 1 2" "${TETRA[@]}" "${IDEAL[@]}" \
                 --set retina.scenes.q_from_lms=after_balance ;;
        C2)  "$P" "$R/C2-seed$S" "$S" 24000 "24000" "0 1 2" --preset main \
                 --cones LMS+M_coexpress_L "${IDEAL[@]}" ;;
        A4)  "$P" "$R/A4-LMS-seed$S" "$S" 12000 "12000" "0 1 2" --preset main --cones LMS
             if [ ! -d "$R/A4-seed$S/checkpoints/step_00024000" ]; then
                 if [ -f "$R/A4-seed$S/metrics.csv" ]; then   # stopped: continue it
                     "$B" resume "$R/A4-seed$S"
                 else
                     "$B" train "${TETRA[@]}" --seed "$S" --steps 12000 \
                         --continue-from "$R/A4-LMS-seed$S" --out "$R/A4-seed$S"
                 fi
             fi
             for L in 0 1 2; do
                 [ -f "$R/A4-seed$S/cmf-sim-step24000-loc$L/cmf_sim.json" ] || "$B" cmf-sim \
                     --run "$R/A4-seed$S" --checkpoint-step 24000 --location-seed "$L" \
                     --out "$R/A4-seed$S/cmf-sim-step24000-loc$L"
             done ;;
        A2a) continue_to "$R/A0-seed$S" "$R/A2a-seed$S" 48000
             "$P" "$R/A2a-seed$S" "$S" 48000 "48000" "0 1 2" ;;
        A2b) continue_to "$R/A2a-seed$S" "$R/A2b-seed$S" 96000
             "$P" "$R/A2b-seed$S" "$S" 96000 "96000" "0 1 2" ;;
        *) echo "fourth-screen.sh: unknown arm $1" >&2; exit 2 ;;
    esac
}

# An arm stopped on another machine continues from its kept copy (runs-kept/fourth/, in the
# repository: its config, metrics and newest checkpoint; scripts/keep-run.sh makes one).
restore() {
    local name kept
    for name in "$@"; do
        kept="$ROOT/runs-kept/fourth/$name-seed$S"
        [ -d "$kept" ] && [ ! -d "$R/$name-seed$S" ] && cp -r "$kept" "$R/$name-seed$S" || true
    done
}

mkdir -p "$R"
for a in ${ARMS:-A0 A0i C1b C1c C2 A3 A4 C1a A2a A2b}; do
    echo "== fourth-screen: arm $a, seed $S ($(date -u +%FT%TZ))"
    restore "$a"
    [ "$a" = A4 ] && restore A4-LMS
    arm "$a"
done
