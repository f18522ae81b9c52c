#!/usr/bin/env python3
"""Every recorded pigeon-Q run (cones `LMSQ,Q:506`): its dimension beside how well its learned
cone-type map C tells the M cones from the Q cones.

Reads `results/*/summary.json`: the dimension (a protocol arm's `protocol_reading`, the median
over its location seeds, or else the run's own final CMF-SIM) and C's k-means recall per class
(`invariants.recovery.c.recall_kmeans`: the share of each class's cones that the k-means
clustering of C's learned cone embeddings puts in the cluster matched to that class). M and Q
peak 24 nm apart (530 and 506 nm), so the smaller of their two recalls says whether C separates
them. Prints a markdown table, runs sorted by that recall; each group's median; the chance that
a 4-D run's smaller recall exceeds a run's below 4 (ties count half; the area under the ROC
curve, which needs no threshold); and the counts on each side of THRESHOLD (default 0.85).

Usage: python3 scripts/c-separation-table.py [THRESHOLD]
"""
import glob
import json
import os
import statistics
import sys


def pigeon_runs(root):
    for d in sorted(glob.glob(os.path.join(root, "results", "*"))):
        try:
            with open(os.path.join(d, "summary.json")) as f:
                s = json.load(f)
            with open(os.path.join(d, "config.toml")) as f:
                config = f.read()
        except (FileNotFoundError, NotADirectoryError):
            continue
        if 'cones = "LMSQ,Q:506"' not in config:
            continue
        c = ((s.get("invariants") or {}).get("recovery") or {}).get("c")
        if not c or c.get("classes") != ["L", "M", "S", "Q"]:
            continue
        reading = s.get("protocol_reading")
        dim = reading["dimension"] if reading else s["dimension"]
        recall = c["recall_kmeans"]
        yield os.path.basename(d), dim, recall[1], recall[3]


def main():
    threshold = float(sys.argv[1]) if len(sys.argv) > 1 else 0.85
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    runs = sorted(pigeon_runs(root), key=lambda r: min(r[2], r[3]))
    print("| run | dimension | C recall M | C recall Q | smaller |")
    print("|---|---|---|---|---|")
    for name, dim, m, q in runs:
        print(f"| `{name}` | {dim} | {m:.2f} | {q:.2f} | {min(m, q):.2f} |")
    four = [min(m, q) for _, d, m, q in runs if d == 4]
    below = [min(m, q) for _, d, m, q in runs if d != 4]
    for label, side in [("4-D", four), ("below 4", below)]:
        print(f"\n{label}: median smaller recall {statistics.median(side):.2f}", end="")
    pairs = [(a > b) + 0.5 * (a == b) for a in four for b in below]
    print(f"\nchance a 4-D run's smaller recall is the larger: {sum(pairs) / len(pairs):.2f}")
    for label, test in [("4-D", lambda d: d == 4), ("below 4", lambda d: d != 4)]:
        side = [min(m, q) for _, d, m, q in runs if test(d)]
        above = sum(v >= threshold for v in side)
        print(f"\n{label}: {len(side)} runs, {above} with the smaller recall ≥ {threshold}, "
              f"{len(side) - above} below", end="")
    print()


if __name__ == "__main__":
    main()
