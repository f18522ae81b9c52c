"""Medians of timed rounds and the median of the per-round ratios ours / each other entry.

Input: a file of lines `NAME MS` (one per timed round and entry; `ours` is the reference
name, or the first argument after the file names the pairs `OURS:THEIRS`, comma-separated).
Used by in_phase.sh and whole_step.sh."""
import collections, statistics, sys

times = collections.defaultdict(list)
for line in open(sys.argv[1]):
    name, ms = line.split()
    times[name].append(float(ms))
for name, v in times.items():
    print(f"{name:24s} median {statistics.median(v):8.2f} ms   rounds {v}")
pairs = ([p.split(":") for p in sys.argv[2].split(",")] if len(sys.argv) > 2
         else [("ours", n) for n in times if n != "ours"])
for ours, theirs in pairs:
    r = [a / b for a, b in zip(times[ours], times[theirs])]
    faster = sum(x < 1 for x in r)
    print(f"{ours} / {theirs}: median {statistics.median(r):.3f} ({ours} faster in {faster} of {len(r)})")
