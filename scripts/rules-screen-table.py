#!/usr/bin/env python3
"""The stage-1 table of the learning-rules protocol from the folders `scripts/rules-screen.sh`
wrote (docs/notebook/2026-12-02-learning-rules-protocol.md, "What is read" and "An arm moves").

Usage: scripts/rules-screen-table.py [SCREEN_DIR]   (default runs/rules-screen; markdown on stdout)

One row per arm found, in the protocol's order:
- steps: the last step in its metrics.csv (3 000 when finished);
- empty warp: the share of steps whose prediction loss (`main_loss`) is exactly 0, and the
  last such step (the protocol asks for none after step 500);
- held-out gain at the end: "next frame = this frame" MSE over the cortex's (summary.json's
  `heldout_prediction[2]`);
- CMF-SIM's dimension at 3 000, location seed 0 (`cmf-sim-step3000-loc0/cmf_sim.json`);
- the mean cosine to backprop per bucket W/C/D/P (metrics.csv's `align_cos_*`);
- the percept against B0's at the last common checkpoint: R² of B0's percept from the arm's,
  and linear CKA (`percept-alignment/against-B0.csv`);
- control and verdict: an arm moves when it has no empty-warp step after step 500, its gain
  is above 1 and at least half its control's (backprop arms are controls, not judged).
"""
import csv
import json
import os
import sys

ORDER = ["B0", "F0", "F1", "B1", "F2", "B2", "F3", "B3", "K1", "D1", "G0", "G1"]
CONTROL = {"F0": "B0", "F1": "B1", "D1": "B1", "F2": "B2", "F3": "B3",
           "K1": "B0", "G0": "B0", "G1": "B0"}
BUCKETS = ["W", "C", "D", "P"]


def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def metrics(arm_dir):
    """(last step, share of empty-warp steps, last empty-warp step, mean cosines per bucket)."""
    path = os.path.join(arm_dir, "metrics.csv")
    if not os.path.exists(path):
        return None
    steps, empty, last_empty = 0, 0, None
    cos = {b: [] for b in BUCKETS}
    with open(path) as f:
        for row in csv.DictReader(f):
            step = int(row["step"])
            steps = max(steps, step)
            if row.get("main_loss") not in (None, "") and float(row["main_loss"]) == 0.0:
                empty += 1
                last_empty = step
            for b in BUCKETS:
                v = row.get(f"align_cos_{b}")
                if v not in (None, ""):
                    cos[b].append(float(v))
    means = {b: (sum(v) / len(v) if v else None) for b, v in cos.items()}
    return steps, empty / max(steps, 1), last_empty, means


def gain(arm_dir):
    s = read_json(os.path.join(arm_dir, "summary.json"))
    h = s and s.get("heldout_prediction")
    return h[2] if h and len(h) == 3 else None


def dimension(arm_dir):
    d = read_json(os.path.join(arm_dir, "cmf-sim-step3000-loc0", "cmf_sim.json"))
    return d["dimension"] if d else None


def against_b0(arm_dir):
    path = os.path.join(arm_dir, "percept-alignment", "against-B0.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows[-1] if rows else None


def fmt(v, spec):
    return "—" if v is None else format(v, spec)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "runs/rules-screen"
    rows, gains = [], {}
    for arm in ORDER:
        d = os.path.join(root, arm)
        m = metrics(d)
        if m is None:
            continue
        gains[arm] = gain(d)
        rows.append((arm, d, m))
    print("| arm | steps | empty warp (last step) | held-out gain | dimension | cos W/C/D/P "
          "| R² of B0's percept, CKA | control | moves |")
    print("|---|---|---|---|---|---|---|---|---|")
    for arm, d, (steps, share, last_empty, cos) in rows:
        g = gains[arm]
        a = against_b0(d)
        align = "—" if a is None else (
            f"{float(a['r2_b_from_a']):.2f}, {float(a['cka']):.2f} (step {a['step']})")
        control = CONTROL.get(arm)
        if control is None:
            verdict = "control"
        elif steps < 3000 or g is None or gains.get(control) is None:
            verdict = "not yet"
        else:
            moves = ((last_empty is None or last_empty <= 500) and g > 1
                     and g >= 0.5 * gains[control])
            verdict = "**yes**" if moves else "no"
        empty = "—" if last_empty is None else f"{share:.1%} ({last_empty})"
        cosines = "/".join(fmt(cos[b], ".2f") for b in BUCKETS)
        print(f"| {arm} | {steps} | {empty} | {fmt(g, '.2f')} | {fmt(dimension(d), 'd')} "
              f"| {cosines} | {align} | {control or '—'} | {verdict} |")


if __name__ == "__main__":
    main()
