#!/bin/bash
# Copies the record of a finished run folder into results/NAME: its settings, start, summary,
# final CMF-SIM and dimension plot (and, when measured, its convergence table, the CMF-SIM of
# its checkpoints, the figure of its checkpoints' averaged weights, its CMFs against Stiles &
# Burch, and a protocol arm's CMF-SIM per checkpoint and location seed, whose median
# dimension at the final step its summary.json then says as `protocol_reading`), and record.json
# naming the folder it was trained in (so that `gather` names a run continued from that folder
# by this record) — the small files the README's tables are generated from
# (`colorvision gather results --markdown`). PROTOCOL, when given, names the protocol that fixed
# the run before it ran — its page and the commit that added it, e.g.
# "docs/notebook/2026-11-28-paper-table-protocol.md @ f0603a6" — and goes into record.json, so
# the runs' index marks the run as pre-registered.
# Its last checkpoint with the parameters only; no pictures or per-step log.
# Usage: scripts/record-run.sh RUN_DIR NAME [PROTOCOL]
set -euo pipefail
USAGE="usage: scripts/record-run.sh RUN_DIR NAME [PROTOCOL]"
RUN=${1:?$USAGE}
NAME=${2:?$USAGE}
PROTOCOL=${3:-}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
[ -f "$RUN/summary.json" ] || { echo "record-run.sh: $RUN/summary.json: not a finished run" >&2; exit 1; }
DEST="$ROOT/results/$NAME"
TMP=$(mktemp -d "$ROOT/results/.tmp.XXXXXX")
trap 'rm -rf "$TMP"' EXIT
for f in config.toml run.json summary.json cmf_sim.json dimension.svg; do
    [ -f "$RUN/$f" ] && cp "$RUN/$f" "$TMP/"
done
json_string() { sed 's/[\\"]/\\&/g'; }   # a JSON string's content: \ and " escaped
# A record names folders relative to the repository root, never as absolute paths of the
# machine it was made on: the folder the run was trained in, and in its run.json the checkpoint
# a continued run started from (`gather` links the two).
from_root() { realpath -m --relative-to="$ROOT" "$1"; }
TRAINED_IN=$(from_root "$RUN" | json_string)
if [ -f "$TMP/run.json" ]; then
    FROM=$(sed -n 's/.*"continued_from": *"\([^"]*\)".*/\1/p' "$TMP/run.json")
    # A run names it from its own folder (older ones by its absolute path).
    case "$FROM" in
        "") REL="" ;;
        /*) REL=$(from_root "$FROM") ;;
        *) REL=$(from_root "$RUN/$FROM") ;;
    esac
    if [ -n "$REL" ]; then
        REL=$(printf '%s' "$REL" | sed 's/[\\&#]/\\&/g')
        sed -i "s#\"continued_from\": *\"[^\"]*\"#\"continued_from\": \"$REL\"#" "$TMP/run.json"
    fi
fi
PROTOCOL_FIELD=""
[ -z "$PROTOCOL" ] || PROTOCOL_FIELD=", \"protocol\": \"$(printf '%s' "$PROTOCOL" | json_string)\""
printf '{"trained_in": "%s"%s}\n' "$TRAINED_IN" "$PROTOCOL_FIELD" > "$TMP/record.json"
[ -f "$RUN/convergence/convergence.md" ] && cp "$RUN/convergence/convergence.md" "$TMP/"
if [ -f "$RUN/convergence/cmf_over_checkpoints.json" ]; then
    mkdir "$TMP/convergence" && cp "$RUN/convergence/cmf_over_checkpoints.json" "$TMP/convergence/"
fi
if [ -f "$RUN/average/average.json" ]; then
    mkdir "$TMP/average" && cp "$RUN/average/average.json" "$TMP/average/"
fi
# CMF-SIM of a protocol arm's checkpoints, one folder per step and location seed
# (scripts/protocol-arm.sh): cmf-sim-step<N>-loc<L>/cmf_sim.json.
for m in "$RUN"/cmf-sim-step*-loc*/cmf_sim.json; do
    [ -f "$m" ] || continue
    d=$(basename "$(dirname "$m")")
    mkdir -p "$TMP/$d" && cp "$m" "$TMP/$d/"
done
# A protocol arm trained without measuring itself (`train`): its summary says the dimension
# its final checkpoint's readings give, the median over an odd number (three or more) of
# location seeds, as `gather` reads them (`cmf-sim-step<N>-loc<L>/`, L an integer).
STEPS=$(grep -m1 -o '"steps": *[0-9]*' "$TMP/summary.json" | grep -o '[0-9]*$')
READINGS=""
for m in "$TMP"/cmf-sim-step"$STEPS"-loc*/cmf_sim.json; do
    [ -f "$m" ] || continue
    L=$(basename "$(dirname "$m")" | sed 's/.*-loc//')
    D=$(grep -m1 -o '"dimension": *[0-9]*' "$m" | grep -o '[0-9]*$')
    [[ "$L" =~ ^[0-9]+$ && -n "$D" ]] || continue
    READINGS="$READINGS$L $D"$'\n'
done
COUNT=$(printf '%s' "$READINGS" | grep -c . || true)
if [ "$COUNT" -ge 3 ] && [ $((COUNT % 2)) -eq 1 ] \
    && grep -q '^  "dimension": 0,' "$TMP/summary.json"; then
    MEDIAN=$(printf '%s' "$READINGS" | awk '{print $2}' | sort -n \
        | awk '{v[NR]=$1} END {print v[(NR+1)/2]}')
    SEEDS=$(printf '%s' "$READINGS" | sort -n | awk '{printf "%s[%s, %s]", (NR>1?", ":""), $1, $2}')
    LINE="  \"protocol_reading\": {\"step\": $STEPS, \"dimension\": $MEDIAN, \"location_seeds\": [$SEEDS], \"files\": \"cmf-sim-step$STEPS-loc<L>/cmf_sim.json\"},"
    awk -v line="$LINE" 'NR == 1 {print; print line; next} {print}' "$TMP/summary.json" \
        > "$TMP/summary.tmp" && mv "$TMP/summary.tmp" "$TMP/summary.json"
fi
# The run's last checkpoint with its parameters only (meta.json and params.safetensors, a third
# of the whole): readings load it (`colorvision cmf-sim --run results/NAME`), so anyone can
# measure the record again; resuming training needs the run folder.
LAST=$(find "$RUN/checkpoints" -maxdepth 1 -name 'step_*' -type d 2>/dev/null | sort | tail -n 1)
if [ -n "$LAST" ]; then
    K="$TMP/checkpoints/$(basename "$LAST")"
    mkdir -p "$K" && cp "$LAST/meta.json" "$LAST/params.safetensors" "$K/"
fi
if [ -f "$RUN/stiles-burch/table.json" ]; then
    mkdir "$TMP/stiles-burch" && cp "$RUN/stiles-burch/table.json" "$TMP/stiles-burch/"
fi
rm -rf "$DEST"
mv "$TMP" "$DEST"
trap - EXIT
echo "recorded $RUN as results/$NAME"
