#!/usr/bin/env python3
"""The fourth dimension's A/B table, every arm and seed, from the records in results/.

Each row is one arm read at one step against its control (the same seed, one change): the
natural log of K3, the best three-primary set's converged worst ratio over the threshold, at
location seeds 0, 1, 2 (> 0: three primaries fail, a fourth dimension), its median, the median's
difference from the control's, the dimension per location seed, and Q's hidden unique R² from the
record's summary (32 held-out scenes; "—" where the summary is of another step). An arm moves
when its median differs from its control's by more than 0.25, the rule the fourth-dimension and
human-Q protocols fixed before their arms ran (the hue-rule protocol's is the same; the updates
A/B was answered by its dimension, 4 or not, and is shown here by the same measure):

- docs/notebook/2026-12-02-fourth-dimension-protocol.md (pigeon Q, seeds 21-23) and its hue-rule
  part, docs/notebook/2026-12-03-hue-rule-protocol.md;
- docs/notebook/2026-12-05-human-q-idealised-protocol.md (human Q, seeds 51-53);
- docs/notebook/2026-12-04-updates-ab-protocol.md (the table's pigeon-Q natural cell, 192 000).

Where a reading is below 3-D its K3 was not searched: the log of its last K's ratio stands in
(an upper bound, marked ≤; a difference from such a control is then a lower bound, ≥), as the
protocols fix; a reading taken with CMF-SIM run on through
K3 (`cmf-sim-stepN-locL-through-k3`) gives the K3 itself. Standard library only.

Usage: scripts/fourth-ab-table.py [RESULTS_DIR]   (default: results)
"""
import json
import math
import os
import statistics
import sys

MOVE = 0.25
PIGEON = "pigeon Q"
HUMAN = "human Q"
UPDATES = "pigeon Q, the table's cell"

# (protocol, seed, arm, the one change, record, step, control as (record, step) or None)
ROWS = [
    (PIGEON, 21, "A0", "control: the table's pigeon-Q natural cell, 24 000 steps",
     "fourth-A0-seed21", 24000, None),
    (PIGEON, 21, "C1a", "Q's plane replaced by its fit from L, M, S before the white balance",
     "fourth-C1a-seed21", 24000, ("fourth-A0-seed21", 24000)),
    (PIGEON, 21, "C1b", "Q's plane replaced by its fit from L, M, S after the white balance",
     "fourth-C1b-seed21", 24000, ("fourth-A0-seed21", 24000)),
    (PIGEON, 21, "A0i", "a tenth of the tiles idealised",
     "fourth-A0i-seed21", 24000, ("fourth-A0-seed21", 24000)),
    (PIGEON, 21, "C1c", "A0i with Q's plane from L, M, S after the balance",
     "fourth-C1c-seed21", 24000, ("fourth-A0i-seed21", 24000)),
    (PIGEON, 21, "C2", "A0i's scenes, a fourth kind in the span of L and M (½L + ½M)",
     "fourth-C2-seed21", 24000, ("fourth-A0i-seed21", 24000)),
    (PIGEON, 21, "A1", "the `large` eye, 128 × 128 cones",
     "fourth-A1-seed21", 24000, ("fourth-A0-seed21", 24000)),
    (PIGEON, 21, "A3", "half the tiles hue-sphere colours",
     "fourth-A3-seed21", 24000, ("fourth-A0-seed21", 24000)),
    (PIGEON, 22, "A0", "control, seed 22", "fourth-A0-seed22", 24000, None),
    (PIGEON, 23, "A0", "control, seed 23", "fourth-A0-seed23", 24000, None),
    (PIGEON, 22, "A3", "half the tiles hue-sphere colours",
     "fourth-A3-seed22", 24000, ("fourth-A0-seed22", 24000)),
    (PIGEON, 23, "A3", "half the tiles hue-sphere colours",
     "fourth-A3-seed23", 24000, ("fourth-A0-seed23", 24000)),
    (PIGEON, 21, "A4", "boosted: an LMS cortex at 12 000 steps, then 12 000 with Q",
     "fourth-A4-seed21", 24000, ("fourth-A0-seed21", 24000)),
    (PIGEON, 21, "A5c", "control: a tenth of the tiles hue-sphere colours, the default hue rule",
     "fourth-A5c-seed21", 24000, None),
    (PIGEON, 21, "A5", "A5c with the max-chroma hue rule",
     "fourth-A5-seed21", 24000, ("fourth-A5c-seed21", 24000)),
    (PIGEON, 21, "A0 retrained", "control of the step arms (same seed and settings)",
     "fourth-A2b-seed21", 24000, None),
    (PIGEON, 21, "A2a", "twice the steps, 48 000",
     "fourth-A2a-seed21", 48000, ("fourth-A2b-seed21", 24000)),
    (PIGEON, 21, "A2b", "four times the steps, 96 000",
     "fourth-A2b-seed21", 96000, ("fourth-A2b-seed21", 24000)),
    (PIGEON, 22, "A2a", "twice the steps, 48 000",
     "fourth-A2a-seed22", 48000, ("fourth-A0-seed22", 24000)),
    (PIGEON, 22, "A2b", "four times the steps, 96 000",
     "fourth-A2b-seed22", 96000, ("fourth-A0-seed22", 24000)),
    (PIGEON, 23, "A2a", "twice the steps, 48 000",
     "fourth-A2a-seed23", 48000, ("fourth-A0-seed23", 24000)),
    (PIGEON, 23, "A2b", "four times the steps, 96 000",
     "fourth-A2b-seed23", 96000, ("fourth-A0-seed23", 24000)),
    (HUMAN, 51, "H0", "control: a tenth of the tiles idealised", "humanq-H0-seed51", 24000, None),
    (HUMAN, 52, "H0", "control: a tenth of the tiles idealised", "humanq-H0-seed52", 24000, None),
    (HUMAN, 53, "H0", "control: a tenth of the tiles idealised", "humanq-H0-seed53", 24000, None),
    (HUMAN, 51, "H1", "half the tiles idealised",
     "humanq-H1-seed51", 24000, ("humanq-H0-seed51", 24000)),
    (HUMAN, 52, "H1", "half the tiles idealised",
     "humanq-H1-seed52", 24000, ("humanq-H0-seed52", 24000)),
    (HUMAN, 53, "H1", "half the tiles idealised",
     "humanq-H1-seed53", 24000, ("humanq-H0-seed53", 24000)),
    (HUMAN, 51, "H2", "the `large` eye, 128 × 128 cones",
     "humanq-H2-seed51", 24000, ("humanq-H0-seed51", 24000)),
    (UPDATES, 31, "96k", "control: LMS + pigeon Q from scratch, natural scenes, 96 000 steps",
     "LMSQ-pigeonQ-surfaces-96k", 96000, None),
    (UPDATES, 31, "192k", "the 96 000-step cell trained on to 192 000 updates",
     "LMSQ-pigeonQ-surfaces-96k-192k", 192000, ("LMSQ-pigeonQ-surfaces-96k", 96000)),
]


def reading(root, record, step, loc):
    """(dimension, log of K3's ratio, whether that log is a stand-in bound) at one location."""
    folder = os.path.join(root, record, f"cmf-sim-step{step}-loc{loc}")
    with open(os.path.join(folder, "cmf_sim.json")) as f:
        main = json.load(f)
    ks = {k["n_primaries"]: k["converged_worst_ratio"] for k in main["per_k"]}
    through = folder + "-through-k3"
    if 3 not in ks and os.path.isdir(through):
        with open(os.path.join(through, "cmf_sim.json")) as f:
            ks.update({k["n_primaries"]: k["converged_worst_ratio"] for k in json.load(f)["per_k"]})
    if 3 in ks:
        return main["dimension"], math.log(ks[3]), False
    return main["dimension"], math.log(ks[max(ks)]), True


def readings(root, record, step):
    """Per-location dimensions, logs and bound marks; the median log."""
    rows = [reading(root, record, step, loc) for loc in (0, 1, 2)]
    return rows, statistics.median(r[1] for r in rows)


def hidden_q(root, record, step):
    """Q's hidden unique R² from the record's summary when it is of this step, else None."""
    with open(os.path.join(root, record, "summary.json")) as f:
        summary = json.load(f)
    hidden = summary.get("invariants", {}).get("recovery", {}).get("hidden") or {}
    if summary.get("steps") != step or "Q" not in hidden.get("classes", []):
        return None
    return hidden["unique_r2"][hidden["classes"].index("Q")]


def signed(value, digits):
    """A signed figure with a minus sign, not a hyphen."""
    return f"{value:+.{digits}f}".replace("-", "\u2212")


def cell(value, bound):
    return ("≤" if bound else "") + signed(value, 3)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "results"
    print("| protocol | seed | arm | the one change | steps | log K3 at location seeds 0, 1, 2 "
          "| median | − control's | dimensions | Q's hidden R² | moves |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for protocol, seed, arm, change, record, step, control in ROWS:
        rows, median = readings(root, record, step)
        logs = ", ".join(cell(r[1], r[2]) for r in rows)
        dims = ", ".join(str(r[0]) for r in rows)
        q = hidden_q(root, record, step)
        q = "—" if q is None else signed(q, 2)
        if control is None:
            diff, moves = "—", "control"
        else:
            control_rows, control_median = readings(root, *control)
            d = median - control_median
            # Against a control's stand-in bound the true difference is at least this.
            at_least = "≥" if any(r[2] for r in control_rows) else ""
            diff, moves = at_least + signed(d, 3), "yes" if abs(d) > MOVE else "no"
        steps = f"{step:,}".replace(",", " ")
        print(f"| {protocol} | {seed} | {arm} | {change} | {steps} | {logs} | "
              f"{cell(median, any(r[2] for r in rows))} | {diff} | {dims} | {q} | {moves} |")


if __name__ == "__main__":
    main()
