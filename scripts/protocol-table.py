#!/usr/bin/env python3
"""The slow-colour protocol's table from its records (results/slow-colour-ARM-seedS-12k/):
per arm, seed and checkpoint, the CMF-SIM dimension per location seed and its median, the
converged margins (median over location seeds), the blue lights' location error; then the
learned invariants of each run. Standard library only.

Usage: scripts/protocol-table.py [RESULTS_DIR]   (default: results)
"""
import glob
import json
import os
import statistics
import sys

ARMS = {"A0": "control", "A1": "leaf radius_min 7.7 px", "A2": "W held at the DoG",
        "B1": "surfaces"}


def reading(path):
    """Dimension, blue and all-wavelength location error, converged margin per K."""
    r = json.load(open(path))
    wl, base, energy = r["test_wavelengths_nm"], r["base_error"], r["energy"]
    blue = [i for i, w in enumerate(wl) if w <= 470]
    return {
        "dim": r["dimension"],
        "blue": sum(base[i] for i in blue) / sum(energy[i] for i in blue),
        "all": sum(base) / sum(energy),
        "ks": {k["n_primaries"]: k["converged_worst_ratio"] for k in r["per_k"]},
    }


def margin(rows, k):
    v = [r["ks"][k] for r in rows if k in r["ks"]]
    if not v:
        return "—"
    note = "" if len(v) == len(rows) else f" ({len(v)} of {len(rows)})"
    return f"{statistics.median(v):.2f}{note}"


def records(root):
    for d in sorted(glob.glob(os.path.join(root, "slow-colour-*-seed*-12k"))):
        arm, seed = os.path.basename(d)[len("slow-colour-"):-len("-12k")].split("-seed")
        yield d, arm, seed


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "results"
    print("| arm | seed | step | dimension, location seeds 0, 1, 2 | median | K1 | K2 | K3 "
          "| blue location error | all wavelengths |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    split = [0, 0]
    for d, arm, seed in records(root):
        for step in (6000, 12000):
            files = sorted(glob.glob(f"{d}/cmf-sim-step{step}-loc*/cmf_sim.json"))
            rows = [reading(f) for f in files]
            if not rows:
                continue
            dims = [r["dim"] for r in rows]
            median = statistics.median(dims) if len(dims) == 3 else "—"
            if len(dims) == 3:
                split[1] += 1
                split[0] += len(set(dims)) > 1
            print(f"| {arm} {ARMS.get(arm, '')} | {seed} | {step} | {', '.join(map(str, dims))} "
                  f"| {median} | {margin(rows, 1)} | {margin(rows, 2)} | {margin(rows, 3)} "
                  f"| {rows[0]['blue']:.3f} | {rows[0]['all']:.3f} |")
    print(f"\nThe three location seeds disagree at {split[0]} of {split[1]} checkpoints.\n")
    print("| arm | seed | C d′ L/M | C d′ S | W DC gain (eye 0.09) | W surround r "
          "| P error, cones (median) | hidden R² L/M/S |")
    print("|---|---|---|---|---|---|---|---|")
    for d, arm, seed in records(root):
        rec = json.load(open(f"{d}/summary.json"))["invariants"]["recovery"]
        c, w, p, h = rec["c"], rec["w"], rec["p"], rec["hidden"]
        print(f"| {arm} | {seed} | {c['dprime'][0]:.1f} | {c['dprime'][2]:.1f} "
              f"| {w['dc_gain']:.2f} | {w['surround_r']:.2f} "
              f"| {p['position_error_median_cones']:.2f} "
              f"| {'/'.join('%.2f' % v for v in h['unique_r2'])} |")


if __name__ == "__main__":
    main()
