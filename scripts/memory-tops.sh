#!/usr/bin/env bash
# The memory estimate against the measured peak at the tops of the settings' ranges: each case
# runs `colorvision COMMAND --preset tiny … --set KEY=TOP` to the end (about 2 minutes a case at
# the tops), one at a time under `nice -n 10`, and prints a Markdown row: the case, the estimate
# the run printed, the peak resident memory (`/usr/bin/time -v`), their ratio, and whether
# peak <= estimate <= 1.3 x peak holds. A case whose estimate is over the limit is refused
# before anything is allocated, and is said so.
#
#   scripts/memory-tops.sh [CASES_FILE]
#
# CASES_FILE: one case a line, `COMMAND|KEY=VALUE` (`#` starts a comment); without it the cases
# below. Outside CI (tests/memory_budget.rs keeps a few in CI).
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
bin="$root/target/release/colorvision"
[ -x "$bin" ] || { echo "build first: cargo build --release"; exit 2; }
cases=$(cat "${1:-/dev/stdin}" 2>/dev/null <<'EOF'
run|cortex.p.hidden=4096
train|cortex.p.hidden=4096
run|cmf_sim.location_pairs=4096
run|cmf_sim.n_test_wavelengths=10000
cmf-sim|cmf_sim.location_pairs=4096
cmf-sim|cmf_sim.n_test_wavelengths=10000
simulate|retina.scenes.tiles=2000
gamut|cmf_sim.n_test_wavelengths=10000
EOF
)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export XDG_CACHE_HOME="$work/.cache" RAYON_NUM_THREADS=1
echo "| command | setting | estimate MiB | peak MiB | estimate/peak | holds |"
echo "|---|---|---|---|---|---|"
echo "$cases" | grep -v '^\s*\(#\|$\)' | while IFS='|' read -r command setting; do
    out="$work/out"
    rm -rf "$out"
    case $command in
        run | train) args=("$command" --preset tiny --steps 1) ;;
        cmf-sim) args=(cmf-sim --observer analytic --preset tiny) ;;
        *) args=("$command" --preset tiny) ;;
    esac
    nice -n 10 /usr/bin/time -v "$bin" "${args[@]}" --set "$setting" --out "$out" \
        >"$work/log" 2>"$work/time"
    code=$?
    estimate=$(grep -o 'estimated peak [0-9]*' "$work/log" | head -n 1 | grep -o '[0-9]*$')
    peak=$(grep 'Maximum resident' "$work/time" | grep -o '[0-9]*$')
    peak=$((peak / 1024))
    if grep -q 'over the limit' "$work/time"; then
        echo "| $command | $setting | ${estimate:-?} | - | - | refused before allocating |"
    elif [ "$code" -ne 0 ] || [ -z "$estimate" ]; then
        echo "| $command | $setting | ${estimate:-?} | $peak | - | exit $code: $(grep 'error' "$work/time" | head -n 1) |"
    else
        ratio=$(echo "scale=2; $estimate / $peak" | bc)
        holds=$(echo "$peak <= $estimate && $estimate <= 1.3 * $peak" | bc)
        echo "| $command | $setting | $estimate | $peak | $ratio | $([ "$holds" = 1 ] && echo yes || echo NO) |"
    fi
done
