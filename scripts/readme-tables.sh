#!/bin/bash
# Writes every generated view of the run records in results/, after a record was added or
# results/paper-rows.toml changed:
#   - README.md, between the lines <!-- results: begin --> and <!-- results: end -->:
#     `colorvision gather results --markdown` (the tally and the short table of the paper's rows);
#   - docs/results.md: `--markdown=rows` (a section per row: verdict, runs, evidence);
#   - results/index.md: `--markdown=runs` (every run, the settings that vary, the invariants).
# `tests/results_table.rs` checks that each file holds exactly that output.
# Usage: scripts/readme-tables.sh [COLORVISION_BINARY]   (default: target/release/colorvision)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=${1:-$ROOT/target/release/colorvision}
[ -x "$BIN" ] || { echo "readme-tables.sh: $BIN: not built (cargo build --release)" >&2; exit 1; }
TABLE=$(mktemp)
OUT=$(mktemp)
trap 'rm -f "$TABLE" "$OUT"' EXIT
cd "$ROOT"
"$BIN" gather results --markdown > "$TABLE"
awk -v table="$TABLE" '
    /^<!-- results: begin -->$/ {
        print; print ""
        while ((getline line < table) > 0) print line
        print ""; state = 1; next
    }
    state == 1 && /^<!-- results: end -->$/ { state = 2; print; next }
    state == 1 { next }
    { print }
    END { if (state != 2) { print "readme-tables.sh: README.md has no <!-- results: begin --> ... <!-- results: end --> lines" > "/dev/stderr"; exit 1 } }
' README.md > "$OUT"
cat "$OUT" > README.md
"$BIN" gather results --markdown=rows > "$OUT" && cat "$OUT" > docs/results.md
"$BIN" gather results --markdown=runs > "$OUT" && cat "$OUT" > results/index.md
echo "README.md ($(wc -l < "$TABLE") lines of it), docs/results.md and results/index.md written from results/"
