#!/usr/bin/env python3
"""The fourth-dimension protocol's step arms against their controls, per seed, and the
replicates' verdict, as the protocol fixes them (docs/notebook/2026-12-02-fourth-dimension-protocol.md,
"What is read, and when an arm moves" and the amendments).

Per seed: the control A0 at 24 000 steps, A2a at 48 000 and A2b at 96 000 (one run trained on),
each with `log K3` at location seeds 0, 1, 2 (the natural log of the best three-primary set's
converged worst ratio; where a verdict is below 3, its last K's log ratio, the protocol's
stand-in, which it called an upper bound: not strictly one, as CMF-SIM draws its primary sets
afresh for each K),
their median, the dimension per location seed and Q's hidden unique R². An arm moves when its
median exceeds its seed's control by more than 0.25. A2b is supported when both replicates
(seeds 21 and 22) move, refuted when neither does, inconclusive otherwise. A reading not taken
yet is shown as "—" and leaves the verdict open.

Each arm's readings are looked for in runs/fourth/ARM-seedS and the folders that continue it,
then in the records results/fourth-ARM-seedS (a continued run's record carries its A0's
readings). Standard library only.

Usage: scripts/fourth-steps-table.py [ROOT]   (default: the repository)
"""
import json
import math
import os
import statistics
import sys

ROOT = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
MOVE = 0.25
SEEDS = {23: "screen", 21: "replicate", 22: "replicate"}
ARMS = [("A0", 24000), ("A2a", 48000), ("A2b", 96000)]


def folders(arm, seed):
    """Where the readings of `arm` at `seed` may be: the run folders first, then the records.
    A2a and A2b continue A0's folder, so they carry its readings: the control is the A0 of the
    same run (the amendment: where a retrained A0 differs from its record, the retrained one's
    readings are the control)."""
    names = {"A0": ["A0", "A2a", "A2b"], "A2a": ["A2a", "A2b"], "A2b": ["A2b"]}[arm]
    runs = [os.path.join(ROOT, "runs", "fourth", f"{n}-seed{seed}") for n in names]
    records = [os.path.join(ROOT, "results", f"fourth-{n}-seed{seed}") for n in reversed(names)]
    return runs + records


def log_k3(path):
    """(log K3 or its last K's stand-in, dimension) of one reading."""
    r = json.load(open(path))
    ratios = {k["n_primaries"]: k["converged_worst_ratio"] for k in r["per_k"]}
    k = 3 if 3 in ratios else max(ratios)
    return math.log(ratios[k]), r["dimension"]


def arm_readings(arm, seed, step):
    """Per location seed (log K3, dimension) or None, and Q's hidden unique R² if known."""
    found = [None, None, None]
    q_r2 = None
    for folder in folders(arm, seed):
        for loc in range(3):
            p = os.path.join(folder, f"cmf-sim-step{step}-loc{loc}", "cmf_sim.json")
            if found[loc] is None and os.path.isfile(p):
                found[loc] = log_k3(p)
        for name in (f"summary_step_{step}.json", "summary.json"):
            s = os.path.join(folder, name)
            if q_r2 is None and os.path.isfile(s):
                summary = json.load(open(s))
                if summary.get("steps") == step or name.startswith("summary_step"):
                    q_r2 = hidden_q(summary)
    return found, q_r2


def hidden_q(summary):
    """Q's hidden unique R² of a summary, if it has one."""
    try:
        hidden = summary["invariants"]["recovery"]["hidden"]
        return hidden["unique_r2"][hidden["classes"].index("Q")]
    except (KeyError, ValueError, TypeError):
        return None


def fmt(x):
    return "—" if x is None else f"{x:+.3f}"


def main():
    print("| seed | arm | steps | log K3 at location seeds 0, 1, 2 | median | − control | "
          "dimension | Q's hidden unique R² | moves |")
    print("|---|---|---|---|---|---|---|---|---|")
    verdicts = {}
    for seed, role in SEEDS.items():
        control = None
        for arm, step in ARMS:
            found, q_r2 = arm_readings(arm, seed, step)
            logs = [f[0] if f else None for f in found]
            dims = ", ".join("—" if f is None else str(f[1]) for f in found)
            median = statistics.median(logs) if None not in logs else None
            if arm == "A0":
                control, diff, moves = median, None, "control"
            else:
                diff = None if None in (median, control) else median - control
                moves = "—" if diff is None else ("yes" if diff > MOVE else "no")
                if arm == "A2b" and role == "replicate":
                    verdicts[seed] = moves
            print(f"| {seed} ({role}) | {arm} | {step} | {', '.join(fmt(x) for x in logs)} | "
                  f"{fmt(median)} | {fmt(diff)} | {dims} | {fmt(q_r2)} | {moves} |")
    moved = [v for v in verdicts.values()]
    if "—" in moved or len(moved) < 2:
        verdict = "open (a replicate's readings are not all taken)"
    elif all(v == "yes" for v in moved):
        verdict = "supported"
    elif all(v == "no" for v in moved):
        verdict = "refuted"
    else:
        verdict = "inconclusive"
    print(f"\nA2b (96 000 steps) on the replicate seeds 21 and 22: **{verdict}**.")


if __name__ == "__main__":
    main()
