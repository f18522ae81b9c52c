#!/bin/bash
# Replaces the README's generated tables (from "| the paper's experiment |" to the last table
# row before "In words:") with what `colorvision gather results --markdown` prints now, after a
# record was added to results/ or results/paper-rows.toml changed. `tests/results_table.rs`
# checks the README holds exactly that output.
# Usage: scripts/readme-tables.sh [COLORVISION_BINARY]   (default: target/release/colorvision)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=${1:-$ROOT/target/release/colorvision}
[ -x "$BIN" ] || { echo "readme-tables.sh: $BIN: not built (cargo build --release)" >&2; exit 1; }
TABLES=$(mktemp)
OUT=$(mktemp)
trap 'rm -f "$TABLES" "$OUT"' EXIT
(cd "$ROOT" && "$BIN" gather results --markdown) > "$TABLES"
awk -v tables="$TABLES" '
    state == 0 && /^\| the paper.s experiment \|/ {
        state = 1
        while ((getline line < tables) > 0) print line
        next
    }
    state == 1 && /^In words:/ { state = 2; print ""; print; next }
    state == 1 { next }
    { print }
    END { if (state != 2) { print "readme-tables.sh: README.md has no generated tables followed by \"In words:\"" > "/dev/stderr"; exit 1 } }
' "$ROOT/README.md" > "$OUT"
# The generated block ends with its last table row; one blank line separates it from the words.
cat -s "$OUT" > "$ROOT/README.md"
echo "README.md: tables regenerated from results/ ($(wc -l < "$TABLES") lines)"
