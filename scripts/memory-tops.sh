#!/usr/bin/env bash
# The memory estimate against the measured peak, and the time a SIGTERM takes to stop the
# command, at the tops of the settings' ranges: each case runs `colorvision COMMAND --preset
# tiny … --set KEY=TOP` to its end (about 2 minutes a case at the tops), one at a time under
# `nice -n 10`, then once more, sent SIGTERM 2 s after it starts, and prints a Markdown row:
# the case, the estimate the run printed, the peak resident memory (`/usr/bin/time -v`), their
# ratio, whether peak <= estimate <= 1.3 x peak holds, and how long the stop took (the promise:
# a stage still running 3 s after the signal stops unfinished). A case whose estimate is over
# the limit is refused before anything is allocated, and is said so.
#
#   scripts/memory-tops.sh [CASES_FILE]
#
# CASES_FILE: one case a line, `COMMAND|KEY=VALUE[|stop-only]` (`#` starts a comment;
# `stop-only`: only the SIGTERM run, for a case whose end is hours away); without it the cases
# below. Outside CI (tests/memory_budget.rs keeps a few in CI, tests/fault_injection the stops).
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
bin="$root/target/release/colorvision"
[ -x "$bin" ] || { echo "build first: cargo build --release"; exit 2; }
cases=$(cat "${1:-/dev/stdin}" 2>/dev/null <<'EOF'
run|cortex.p.hidden=4096|stop-only
train|cortex.p.hidden=4096|stop-only
run|cmf_sim.location_pairs=4096|stop-only
run|cmf_sim.n_test_wavelengths=10000|stop-only
cmf-sim|cmf_sim.location_pairs=4096
cmf-sim|cmf_sim.n_test_wavelengths=10000
simulate|retina.scenes.tiles=2000
gamut|cmf_sim.n_test_wavelengths=10000
run|retina.scenes.tiles=1000
EOF
)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export XDG_CACHE_HOME="$work/.cache" RAYON_NUM_THREADS=1

# Seconds from a SIGTERM sent 2 s into the command to its exit, with its exit code; or that
# it ended before the signal.
stop_time() {
    rm -rf "$work/out"
    nice -n 10 "$bin" "$@" --out "$work/out" >/dev/null 2>"$work/stop.err" &
    local pid=$! t0 t1 code
    sleep 2
    if ! kill -0 "$pid" 2>/dev/null; then
        wait "$pid"
        if grep -q 'over the limit' "$work/stop.err"; then
            echo "refused before allocating"
        else
            echo "ended before the signal"
        fi
        return
    fi
    t0=$(date +%s.%N)
    kill -TERM "$pid"
    wait "$pid"
    code=$?
    t1=$(date +%s.%N)
    printf '%.1f s (exit %s)' "$(echo "$t1 - $t0" | bc)" "$code"
}

echo "| command | setting | estimate MiB | peak MiB | estimate/peak | holds | SIGTERM 2 s in: stopped in |"
echo "|---|---|---|---|---|---|---|"
echo "$cases" | grep -v '^\s*\(#\|$\)' | while IFS='|' read -r command setting mode; do
    case $command in
        run | train) args=("$command" --preset tiny --steps 1) ;;
        cmf-sim) args=(cmf-sim --observer analytic --preset tiny) ;;
        *) args=("$command" --preset tiny) ;;
    esac
    args+=(--set "$setting")
    stop=$(stop_time "${args[@]}")
    estimate=$(COLORVISION_MEMORY_LIMIT_MIB=1 "$bin" "${args[@]}" --out "$work/none" 2>&1 \
        | grep -o 'estimated peak [0-9]*' | head -n 1 | grep -o '[0-9]*$')
    if [ "$mode" = stop-only ]; then
        echo "| $command | $setting | ${estimate:-?} | not run to its end | - | - | $stop |"
        continue
    fi
    rm -rf "$work/out"
    nice -n 10 /usr/bin/time -v "$bin" "${args[@]}" --out "$work/out" \
        >"$work/log" 2>"$work/time"
    code=$?
    peak=$(grep 'Maximum resident' "$work/time" | grep -o '[0-9]*$')
    peak=$((peak / 1024))
    if grep -q 'over the limit' "$work/time"; then
        echo "| $command | $setting | ${estimate:-?} | - | - | refused before allocating | $stop |"
    elif [ "$code" -ne 0 ] || [ -z "$estimate" ]; then
        echo "| $command | $setting | ${estimate:-?} | $peak | - | exit $code: $(grep 'error' "$work/time" | head -n 1) | $stop |"
    else
        ratio=$(echo "scale=2; $estimate / $peak" | bc)
        holds=$(echo "$peak <= $estimate && $estimate <= 1.3 * $peak" | bc)
        echo "| $command | $setting | $estimate | $peak | $ratio | $([ "$holds" = 1 ] && echo yes || echo NO) | $stop |"
    fi
done
