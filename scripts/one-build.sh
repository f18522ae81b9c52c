#!/bin/bash
# The README's two commands share one build: after `cargo test --release` has built the tests,
# `cargo build --release` (what `cargo run --release` builds) must compile nothing. Run from a
# fresh clone to see the whole cost (the test build), or anywhere to check that the second
# build is fresh. Exits 1, naming each crate it had to compile, when it is not.
#
# Usage: scripts/one-build.sh
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
cargo test --release --no-run 2>&1 | tail -n 1
echo "one-build.sh: test build $(( $(date +%s) - start )) s"
start=$(date +%s)
compiled=$(cargo build --release 2>&1 | grep -E '^\s*Compiling' || true)
echo "one-build.sh: then cargo build --release $(( $(date +%s) - start )) s"
if [ -n "$compiled" ]; then
    echo "one-build.sh: cargo build --release compiled again:" >&2
    echo "$compiled" >&2
    exit 1
fi
echo "one-build.sh: every crate fresh"
