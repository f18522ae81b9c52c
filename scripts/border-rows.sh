#!/bin/bash
# The table's border rows (docs/notebook/2026-12-04-border-rows-protocol.md), one run after
# another on one thread, each with exactly the protocol's command (scripts/protocol-arm.sh):
# B1, the no-demosaicker cell trained again from its record's settings and read at location
# seeds 0, 1, 2; B2, L:M:S 1:1:1 on seeds 41 and 42, each read at location seeds 0, 1, 2; B3,
# the same eye on the same seeds in the scenes of the earlier 1:1:1 record (dead leaves with
# hue-sphere tiles), the A/B of the scenes; B4, the same eye on the same seeds in surface scenes
# with a tenth of hue-sphere tiles (which part of B3's scenes); B5, the no-demosaicker cell's
# settings on seeds 41 and 42 in surface scenes (S) and in dead leaves (D), the A/B of its scenes;
# B6, B2's eye and scenes trained 48 000 steps, the A/B of the count.
# Running it again continues (a stopped run resumes from its newest checkpoint, a measured
# location seed is skipped; a run kept in runs-kept/border/ is restored first).
#
# Usage: nice -n 10 scripts/border-rows.sh
#   RUNS="B1" scripts/border-rows.sh           only those (B1, B2-41, B2-42, B3-41, B3-42, B4-41,
#                                              B4-42, B5-S-41, B5-S-42, B5-D-41, B5-D-42,
#                                              B6-41, B6-42)
#   COLORVISION=path/to/colorvision            the binary (default target/release/colorvision)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
P="$ROOT/scripts/protocol-arm.sh"
R="$ROOT/runs/border"
export COLORVISION=${COLORVISION:-$ROOT/target/release/colorvision} RAYON_NUM_THREADS=1

restore() {
    local kept="$ROOT/runs-kept/border/$1"
    if [ -d "$kept" ] && [ ! -d "$R/$1" ]; then cp -r "$kept" "$R/$1"; fi
}

mkdir -p "$R"
for run in ${RUNS:-B1 B2-41 B2-42}; do
    echo "== border-rows: $run ($(date -u +%FT%TZ))"
    case "$run" in
        B1) restore no-demosaicker-seed0
            "$P" "$R/no-demosaicker-seed0" 0 8000 "8000" "0 1 2" \
                --config "$ROOT/results/LMS-baseline-no-demosaicker-surfaces-8k/config.toml" ;;
        B2-41 | B2-42)
            S=${run#B2-}
            restore "LMS-1to1to1-seed$S"
            "$P" "$R/LMS-1to1to1-seed$S" "$S" 12000 "12000" "0 1 2" \
                --preset main --cones iid,L=1,M=1,S=1 ;;
        B3-41 | B3-42)
            S=${run#B3-}
            restore "LMS-1to1to1-deadleaves-seed$S"
            "$P" "$R/LMS-1to1to1-deadleaves-seed$S" "$S" 12000 "12000" "0 1 2" \
                --config "$ROOT/results/LMS-1to1to1-main-12k/config.toml" \
                --set retina.scenes.generator=dead_leaves \
                --set cortex.p.log_scale_bound=2.0 \
                --set cortex.train.alignment_every_steps=100 ;;
        B4-41 | B4-42)
            S=${run#B4-}
            restore "LMS-1to1to1-surfaces-hue-seed$S"
            "$P" "$R/LMS-1to1to1-surfaces-hue-seed$S" "$S" 12000 "12000" "0 1 2" \
                --preset main --cones iid,L=1,M=1,S=1 \
                --set retina.scenes.tetra.environment=HueSphere \
                --set retina.scenes.tetra.fraction=0.1 ;;
        B5-S-41 | B5-S-42 | B5-D-41 | B5-D-42)
            S=${run##*-}
            case "$run" in
                B5-S-*) name="no-demosaicker-surfaces-seed$S" scenes=surfaces ;;
                *) name="no-demosaicker-deadleaves-seed$S" scenes=dead_leaves ;;
            esac
            restore "$name"
            "$P" "$R/$name" "$S" 8000 "8000" "0 1 2" \
                --config "$ROOT/results/LMS-baseline-no-demosaicker-surfaces-8k/config.toml" \
                --set retina.scenes.generator=$scenes ;;
        B6-41 | B6-42)
            S=${run#B6-}
            restore "LMS-1to1to1-48k-seed$S"
            "$P" "$R/LMS-1to1to1-48k-seed$S" "$S" 48000 "48000" "0 1 2" \
                --preset main --cones iid,L=1,M=1,S=1 ;;
        *) echo "border-rows.sh: unknown run $run" >&2; exit 2 ;;
    esac
done
