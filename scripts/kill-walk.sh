#!/usr/bin/env bash
# Kills a fresh run with a real SIGKILL at its Nth write(2) (every write: files, stdout,
# stderr), then at its Nth rename or link, for N = 1, 2, … until the run ends before the Nth,
# and checks after each kill that `colorvision resume DIR` continues the run (or says it was
# never started, and the same command then starts it afresh) and that the run ends with the
# files of a run that never stopped, no temporary and no lock.
#
# Uses strace's fault injection (`-e inject=SYSCALL:signal=KILL:when=N`), so it runs outside CI;
# tests/fault_injection/kill_points.rs walks the same points with COLORVISION_FAULT in CI.
#
#   scripts/kill-walk.sh [STEPS] [FIRST_N] [LAST_N]
#
# Prints one line per kill point (kind, N, what the kill left, how it recovered) and a final
# tally; exits 1 if any point did not recover. Run it under `nice -n 10`; it uses the release
# binary (`cargo build --release` first).
set -u
steps=${1:-20}
first=${2:-1}
last=${3:-100000}
root=$(cd "$(dirname "$0")/.." && pwd)
bin="$root/target/release/colorvision"
command -v strace >/dev/null || { echo "strace is needed (apt-get install strace)"; exit 2; }
[ -x "$bin" ] || { echo "build first: cargo build --release"; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
export XDG_CACHE_HOME="$work/.cache" RAYON_NUM_THREADS=1
run() { "$bin" run --preset tiny --steps "$steps" --out "$@"; }
listing() { (cd "$1" && find . -mindepth 1 | sort); }

run ref >/dev/null 2>&1 || { echo "the unbroken run failed"; exit 1; }
listing ref >ref.txt
failed=0
points=0
for kind in write rename; do
    case $kind in
        write) syscalls=write ;;
        rename) syscalls=rename,renameat,renameat2,link,linkat ;;
    esac
    n=$first
    while [ "$n" -le "$last" ]; do
        rm -rf D
        strace -f -o /dev/null -e trace=$syscalls -e inject=$syscalls:signal=KILL:when=$n \
            "$bin" run --preset tiny --steps "$steps" --out D >/dev/null 2>&1
        code=$?
        if [ "$code" -eq 0 ]; then
            break
        fi
        left=$( [ -d D ] && (cd D && ls -A | tr '\n' ' ') || echo "(no folder)")
        how=resumed
        if ! "$bin" resume D >resume.log 2>&1; then
            if grep -q "was never started" resume.log; then
                how="never started, run again"
                run D >again.log 2>&1 || how="run again FAILED: $(tail -1 again.log)"
            else
                how="resume FAILED: $(tail -1 resume.log)"
            fi
        fi
        if [ -d D ]; then
            listing D >got.txt
            if ! cmp -s ref.txt got.txt; then
                how="$how; FILES DIFFER: $(diff ref.txt got.txt | grep '^[<>]' | tr '\n' ' ')"
            fi
        else
            how="$how; NO FOLDER"
        fi
        case $how in *FAIL*|*DIFFER*|*NO\ FOLDER*) failed=$((failed + 1)) ;; esac
        points=$((points + 1))
        echo "$kind $n: killed (exit $code), left: $left-> $how"
        n=$((n + 1))
    done
done
echo "kill points: $points, not recovered: $failed"
[ "$failed" -eq 0 ]
