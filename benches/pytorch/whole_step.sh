#!/usr/bin/env bash
# The whole cortex step, ours (`cargo bench --bench cortex_step -- quick paper`: the quick
# step with oracle motion, its cortex part, and the paper step on a synthetic batch) and
# PyTorch's port (cortex_step.py, channels-last D, the same shapes and ops), in alternating
# rounds on two threads each: this VM's speed drifts by tens of per cent over minutes, so
# only times taken in the same minutes compare. Prints every round, the medians, and the
# median of the per-round ratios ours / PyTorch for each eye.
#
# Usage (from the repository root): benches/pytorch/whole_step.sh ROUNDS PYTHON
#   PYTHON: an interpreter with torch 2.15 (see conv_anchor.py), e.g. venv/bin/python.
# Not part of the build or the tests. Needs a quiet machine: nothing else on the two cores.
set -euo pipefail
rounds=${1:?rounds}
python=${2:?python with torch}
here=$(dirname "$0")
export RAYON_NUM_THREADS=2
cargo bench --bench cortex_step --no-run >/dev/null 2>&1
out=$(mktemp)
for _ in $(seq "$rounds"); do
  cargo bench --bench cortex_step -- quick paper 2>/dev/null | awk '
    /^quick, oracle motion/ { for (i = 1; i <= NF; i++) if ($i == "cortex") print "ours_quick", $(i + 1) }
    /^paper:/ { for (i = 1; i <= NF; i++) if ($i == "step") print "ours_paper", $(i + 1) }' >>"$out"
  (cd "$here" && "$python" cortex_step.py 10 quick channels_last && "$python" cortex_step.py 3 paper channels_last) 2>/dev/null |
    awk '/median/ { print "torch_" $4, $(NF - 1) }' >>"$out"
done
python3 "$here/ratios.py" "$out" ours_quick:torch_quick,ours_paper:torch_paper
rm -f "$out"
