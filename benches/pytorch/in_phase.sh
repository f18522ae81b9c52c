#!/usr/bin/env bash
# Our (4,16,256,256)→16 conv fwd+bwd (benches/conv.rs, direct kernels) and PyTorch's
# channels-last anchor (conv_anchor.py, zero and reflect padding), in alternating rounds: this
# VM's speed drifts by tens of per cent over minutes, so only times taken in the same minutes
# compare. Prints every round, the medians, and the median of the per-round ratios ours / PyTorch.
#
# Usage (from the repository root): benches/pytorch/in_phase.sh ROUNDS PYTHON
#   PYTHON: an interpreter with torch 2.15 (see conv_anchor.py), e.g. venv/bin/python.
# Not part of the build or the tests.
set -euo pipefail
rounds=${1:?rounds}
python=${2:?python with torch}
here=$(dirname "$0")
cargo bench --bench conv --no-run >/dev/null 2>&1
out=$(mktemp)
for _ in $(seq "$rounds"); do
  cargo bench --bench conv -- 'fwd_bwd/\(4,16,256.*direct' --measurement-time 3 --warm-up-time 1 2>/dev/null |
    awk '/time:/ { for (i = 1; i <= NF; i++) if ($i == "time:") print "ours", $(i + 3) }' >>"$out"
  "$python" "$here/conv_anchor.py" 30 256 channels_last 2>/dev/null |
    awk '/median/ { print "torch_" $4 "_cl", $(NF - 1) }' >>"$out"
done
python3 "$here/ratios.py" "$out"
rm -f "$out"
