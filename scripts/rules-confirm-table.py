#!/usr/bin/env python3
"""The stage-2 table of the learning-rules protocol from the folders `scripts/rules-confirm.sh`
wrote (docs/notebook/2026-12-02-learning-rules-protocol.md: stage 2, G1 on seeds 10-12 beside
B0; stage 2b, F2 on seeds 13-15 beside B2).

Usage: scripts/rules-confirm-table.py ARM [CONFIRM_DIR]
       (default runs/rules-confirm; markdown on stdout)

One row per run found (ARM and its backprop control on each seed, seeds in order):
- steps: the last step in its metrics.csv (12 000 when finished);
- empty warp: the share of steps whose prediction loss is exactly 0, and the last such step;
- held-out gain at the end (summary.json's `heldout_prediction[2]`);
- CMF-SIM at 12 000, location seeds 0, 1, 2: the dimension at each, their median, and the
  medians of log K2 and log K3 (the best two- and three-primary sets' converged worst ratios:
  below 0 that many primaries match; "—" where the search stopped before that K);
- the mean cosine to backprop per bucket W/C/D/P (metrics.csv's `align_cos_*`);
- the rule run's percept against its seed's backprop run at the last common checkpoint: R² of
  backprop's percept read from the rule's, and linear CKA
  (`percept-alignment/against-CONTROL-seedS.csv`).
Then the protocol's verdict: the rule learns colour when its median dimension is 3 on at least
two of the three seeds (stage 2b also asks those seeds for a held-out gain above 1 and no
empty-warp step; G1 met both on every seed, so the one rule serves both stages).
"""
import csv
import importlib.util
import math
import os
import statistics
import sys

_spec = importlib.util.spec_from_file_location(
    "rules_screen_table",
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "rules-screen-table.py"))
_screen = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_screen)
BUCKETS, fmt, gain, metrics, read_json = (
    _screen.BUCKETS, _screen.fmt, _screen.gain, _screen.metrics, _screen.read_json)

# Each confirmed arm's seeds and control (scripts/rules-arms.sh: arm_control).
SEEDS = {"G1": [10, 11, 12], "F2": [13, 14, 15]}
CONTROL = {"G1": "B0", "F2": "B2"}
STEPS = 12000


def readings(run_dir):
    """(dimensions per location seed, K2 and K3 converged worst ratios) of the 12 000-step
    readings (a K the search did not reach has none)."""
    dims, k2, k3 = [], [], []
    for loc in (0, 1, 2):
        d = read_json(os.path.join(run_dir, f"cmf-sim-step{STEPS}-loc{loc}", "cmf_sim.json"))
        if d is None:
            continue
        dims.append(d["dimension"])
        per_k = d.get("per_k", [])
        if len(per_k) >= 2 and per_k[1].get("converged_worst_ratio") is not None:
            k2.append(per_k[1]["converged_worst_ratio"])
        if len(per_k) >= 3 and per_k[2].get("converged_worst_ratio") is not None:
            k3.append(per_k[2]["converged_worst_ratio"])
    return dims, k2, k3


def against(run_dir, control, seed):
    path = os.path.join(run_dir, "percept-alignment", f"against-{control}-seed{seed}.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows[-1] if rows else None


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: scripts/rules-confirm-table.py ARM [CONFIRM_DIR]")
    arm = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) > 2 else "runs/rules-confirm"
    if arm not in SEEDS:
        sys.exit(f"rules-confirm-table.py: {arm} was not confirmed (known: {', '.join(SEEDS)})")
    control, seeds = CONTROL[arm], SEEDS[arm]
    print("| seed | run | steps | empty warp (last step) | held-out gain | dimension at "
          "location seeds 0, 1, 2 (median) | median log K2 / log K3 | cos W/C/D/P | R² of backprop's "
          "percept, CKA |")
    print("|---|---|---|---|---|---|---|---|---|")
    medians, passes = {}, {}
    for seed in seeds:
        for run in (control, arm):
            d = os.path.join(root, f"{run}-seed{seed}")
            m = metrics(d)
            if m is None:
                continue
            steps, share, last_empty, cos = m
            dims, k2, k3 = readings(d)
            median_dim = statistics.median(dims) if len(dims) == 3 else None
            if run == arm:
                medians[seed] = median_dim
                passes[seed] = last_empty is None and (gain(d) or 0.0) > 1.0
            dim_text = "—" if not dims else (
                ", ".join(str(x) for x in dims)
                + ("" if median_dim is None else f" ({median_dim:g})"))
            log_k2 = statistics.median(math.log(r) for r in k2) if len(k2) == 3 else None
            log_k3 = statistics.median(math.log(r) for r in k3) if len(k3) == 3 else None
            empty = "—" if last_empty is None else f"{share:.1%} ({last_empty})"
            cosines = "—" if run == control else "/".join(fmt(cos[b], ".2f") for b in BUCKETS)
            a = against(d, control, seed) if run == arm else None
            align = "—" if a is None else (
                f"{float(a['r2_b_from_a']):.2f}, {float(a['cka']):.2f} (step {a['step']})")
            print(f"| {seed} | {run} | {steps} | {empty} | {fmt(gain(d), '.2f')} | {dim_text} "
                  f"| {fmt(log_k2, '+.3f')} / {fmt(log_k3, '+.3f')} | {cosines} | {align} |")
    done = [s for s in seeds if medians.get(s) is not None]
    threes = sum(1 for s in done if medians[s] == 3 and passes[s])
    best_case = threes + len(seeds) - len(done)
    if len(done) < len(seeds) and best_case < 2:
        print(f"\n{arm}: median dimension 3 on {threes} of the {len(done)} seeds read; even if "
              f"every seed left reads 3, at most {best_case} of {len(seeds)} can: **does not "
              "learn colour** (the protocol asks for at least two; the seeds left are still "
              "reported).")
    elif len(done) < len(seeds):
        print(f"\n{arm}: {len(done)} of {len(seeds)} seeds read so far "
              f"({threes} with median dimension 3); the verdict waits for all three.")
    else:
        verdict = "learns colour" if threes >= 2 else "does not learn colour"
        print(f"\n{arm}: median dimension 3 on {threes} of {len(seeds)} seeds: **{verdict}** "
              "(the protocol asks for at least two).")


if __name__ == "__main__":
    main()
