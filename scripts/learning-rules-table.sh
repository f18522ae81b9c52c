#!/bin/bash
# The table of learning rules on the default run's eye (docs/learning-rules.md, "The table"):
# the `main` preset (the default of `run` and `train`) trained 12 000 steps and measured as a
# run is (CMF-SIM over steps, held-out gain, invariants, the rule against backprop every 100
# steps) — backprop and forward-forward on seeds 0, 1, 2; feedback alignment and direct
# feedback alignment on seed 0 with three feedback draws; controls on seed 0: backprop and FA
# with D frozen, FA with sign-concordant feedback and the same feedback sign-flipped — then
# each rule's step time relative to backprop (criterion, `benches/learning_rules.rs`), and
# the table in markdown (scripts/learning-rules-table.py) in OUT_DIR/table.md.
#
# Each part is a sweep spec in scripts/learning-rules-table/; every run is a sweep task, so
# running this again continues: finished runs are skipped, interrupted ones resume from their
# checkpoints. A run that stops on a non-finite loss is a result (the table counts it).
#
# Usage: scripts/learning-rules-table.sh OUT_DIR [COLORVISION_BINARY]
#   JOBS=N        runs at once (default 1), each sweep's runs one after another in a lane of
#                 its own; set RAYON_NUM_THREADS=1 with JOBS=2 on two cores
#   SKIP_BENCH=1  no step-time benchmark (the column stays empty)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:?usage: scripts/learning-rules-table.sh OUT_DIR [COLORVISION_BINARY]}
BIN=${2:-$ROOT/target/release/colorvision}
[ -x "$BIN" ] || { echo "learning-rules-table.sh: $BIN: not built (cargo build --release)" >&2; exit 1; }
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
# The seeds sweep first: forward-forward's steps take several times backprop's, so it is the
# longest; the rules' sweeps, then the controls, share the other lanes one after another.
SWEEPS=(seeds fa-draws dfa-draws sign-flip d-frozen)
for spec in "$ROOT"/scripts/learning-rules-table/*.toml; do   # and any other spec there
    name=$(basename "$spec" .toml)
    [[ " ${SWEEPS[*]} " == *" $name "* ]] || SWEEPS+=("$name")
done
for name in "${SWEEPS[@]}"; do
    [ -f "$OUT/$name/sweep.json" ] \
        || "$BIN" sweep "$ROOT/scripts/learning-rules-table/$name.toml" --out "$OUT/$name"
done
export BIN OUT
printf '%s\n' "${SWEEPS[@]}" | xargs -P "${JOBS:-1}" -I{} sh -c \
    '"$BIN" sweep --local -j 1 "$OUT/{}" \
        || echo "learning-rules-table.sh: not every run of {} finished (see $OUT/{}/logs)"'
if [ -z "${SKIP_BENCH:-}" ]; then
    (cd "$ROOT" && cargo bench --bench learning_rules)
    rm -rf "$OUT/learning_rule_step"
    cp -r "$ROOT/target/criterion/learning_rule_step" "$OUT/"
fi
python3 "$ROOT/scripts/learning-rules-table.py" "$OUT" "$OUT" > "$OUT/table.md"
cat "$OUT/table.md"
