#!/usr/bin/env python3
"""The fourth dimension's A/B table, every arm and seed, from the records in results/.

Each row is one arm read at one step against its control (the same seed, one change): the
natural log of K3, the best three-primary set's converged worst ratio over the threshold, at
location seeds 0, 1, 2 (> 0: three primaries fail, a fourth dimension), its median, the median's
difference from the control's, the dimension per location seed, Q's hidden unique R² from the
record's summary (32 held-out scenes; "—" where the summary is of another step or the eye has no
Q), and the verdict by the rule its protocol fixed before the arm ran:

- `shift`: the arm moves when its median differs from its control's by more than 0.25 (the
  fourth-dimension protocol, docs/notebook/2026-12-02-fourth-dimension-protocol.md, pigeon Q on
  seeds 21-23, its controls C1b and C1c included; the human-Q protocol,
  docs/notebook/2026-12-05-human-q-idealised-protocol.md, seeds 51-53);
- `up`: the arm moves when its median is above its control's by at least 0.25 (the hue-rule
  protocol, docs/notebook/2026-12-03-hue-rule-protocol.md);
- `dimension`: the answer is the median of the three verdicts (C2, which must read 3; the updates
  A/B, docs/notebook/2026-12-04-updates-ab-protocol.md, which answers "updates" if it reads 4);
- `reported`: read and shown, not judged (C1a; A0i, the control of C1c and C2; the
  twice-the-steps arms A2a).

Where a reading is below 3-D its K3 was not searched: the log of its last K's ratio stands in,
as the protocols fix (marked †, and so is a median or difference it enters); a reading taken
with CMF-SIM run on through K3 (`cmf-sim-stepN-locL-through-k3`) gives the K3 itself. The
protocols called the stand-in an upper bound; it is not strictly one, since CMF-SIM draws its
primary sets afresh for each K (paper S-04) and the best three-primary set drawn can match worse
than the best two (humanq-H2-seed51 through K3: K3 above K2 at two of three location seeds).
Standard library only.

Usage: scripts/fourth-ab-table.py [RESULTS_DIR]   (default: results)
"""
import functools
import importlib.util
import json
import os
import statistics
import sys

# One reading's log K3 (or its last K's stand-in) and the 0.25 rule: the step arms' table's.
_spec = importlib.util.spec_from_file_location(
    "fourth_steps_table",
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "fourth-steps-table.py"))
_steps = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_steps)
log_k3, MOVE = _steps.log_k3, _steps.MOVE

PIGEON = "pigeon Q"
HUMAN = "human Q"
UPDATES = "pigeon Q, the table's cell"
A0_21 = ("fourth-A0-seed21", 24000)
A0I_21 = ("fourth-A0i-seed21", 24000)

# (protocol, seed, arm, the one change, record, step, control as (record, step) or None, rule)
SCREEN = [
    (PIGEON, 21, "A0", "control: the table's pigeon-Q natural cell, 24 000 steps",
     "fourth-A0-seed21", 24000, None, "control"),
    (PIGEON, 21, "C1a", "Q's plane replaced by its fit from L, M, S before the white balance "
     "(the balance's own Q signal stays)", "fourth-C1a-seed21", 24000, A0_21, "reported"),
    (PIGEON, 21, "C1b", "Q's plane replaced by its fit from L, M, S after the white balance "
     "(no Q signal of its own)", "fourth-C1b-seed21", 24000, A0_21, "shift"),
    (PIGEON, 21, "A0i", "a tenth of the tiles idealised (the control of C1c and C2)",
     "fourth-A0i-seed21", 24000, A0_21, "reported"),
    (PIGEON, 21, "C1c", "A0i with Q's plane from L, M, S after the balance",
     "fourth-C1c-seed21", 24000, A0I_21, "shift"),
    (PIGEON, 21, "C2", "A0i's scenes, a fourth kind in the span of L and M (½L + ½M)",
     "fourth-C2-seed21", 24000, A0I_21, "dimension"),
    (PIGEON, 21, "A1", "the `large` eye, 128 × 128 cones",
     "fourth-A1-seed21", 24000, A0_21, "shift"),
    (PIGEON, 21, "A4", "boosted: an LMS cortex at 12 000 steps, then 12 000 with Q",
     "fourth-A4-seed21", 24000, A0_21, "shift"),
    (PIGEON, 21, "A5c", "control: a tenth of the tiles hue-sphere colours, the default hue rule",
     "fourth-A5c-seed21", 24000, None, "control"),
    (PIGEON, 21, "A5", "A5c with the max-chroma hue rule",
     "fourth-A5-seed21", 24000, ("fourth-A5c-seed21", 24000), "up"),
]
# A3 against each seed's A0; seeds 22 and 23 are its replicates.
HUE_SPHERE = [
    (PIGEON, seed, "A0", f"control, seed {seed}", f"fourth-A0-seed{seed}", 24000, None, "control")
    for seed in (22, 23)
] + [
    (PIGEON, seed, "A3", "half the tiles hue-sphere colours", f"fourth-A3-seed{seed}", 24000,
     (f"fourth-A0-seed{seed}", 24000), "shift")
    for seed in (21, 22, 23)
]
# The step arms continue A0's own folder; seed 21's control is its A0 trained again (the
# record's CPU differed), kept in the A2b record at 24 000 steps.
STEP_CONTROL = {21: ("fourth-A2b-seed21", 24000), 22: ("fourth-A0-seed22", 24000),
                23: ("fourth-A0-seed23", 24000)}
STEPS = [(PIGEON, 21, "A0 retrained", "control of the step arms (same seed and settings)",
          "fourth-A2b-seed21", 24000, None, "control")] + [
    row for seed in (21, 22, 23) for row in [
        (PIGEON, seed, "A2a", "twice the steps, 48 000", f"fourth-A2a-seed{seed}", 48000,
         STEP_CONTROL[seed], "reported"),
        (PIGEON, seed, "A2b", "four times the steps, 96 000", f"fourth-A2b-seed{seed}", 96000,
         STEP_CONTROL[seed], "shift"),
    ]
]
HUMAN_Q = [
    (HUMAN, seed, arm, change, f"humanq-{arm}-seed{seed}", 24000,
     None if arm == "H0" else (f"humanq-H0-seed{seed}", 24000),
     "control" if arm == "H0" else "shift")
    for arm, change, seeds in [("H0", "control: a tenth of the tiles idealised", (51, 52, 53)),
                               ("H1", "half the tiles idealised", (51, 52, 53)),
                               ("H2", "the `large` eye, 128 × 128 cones", (51,))]
    for seed in seeds
]
UPDATES_AB = [
    (UPDATES, 31, "96k", "control: LMS + pigeon Q from scratch, natural scenes, 96 000 steps",
     "LMSQ-pigeonQ-surfaces-96k", 96000, None, "control"),
    (UPDATES, 31, "192k", "the 96 000-step cell trained on to 192 000 updates",
     "LMSQ-pigeonQ-surfaces-96k-192k", 192000, ("LMSQ-pigeonQ-surfaces-96k", 96000),
     "dimension"),
]
ROWS = SCREEN + HUE_SPHERE + STEPS + HUMAN_Q + UPDATES_AB

def reading(root, record, step, loc):
    """(dimension, log of K3's ratio, whether that log is its last K's stand-in) at one location.
    A verdict below 3 never searched K3; a reading run on through K3 beside it supplies it."""
    folder = os.path.join(root, record, f"cmf-sim-step{step}-loc{loc}")
    log, dimension = log_k3(os.path.join(folder, "cmf_sim.json"))
    if dimension >= 3:
        return dimension, log, False
    through = os.path.join(folder + "-through-k3", "cmf_sim.json")
    if os.path.isfile(through):
        return dimension, log_k3(through)[0], False
    return dimension, log, True


@functools.lru_cache(maxsize=None)
def readings(root, record, step):
    """The three location seeds' (dimension, log K3, stand-in); the median log and whether a
    stand-in enters it."""
    rows = tuple(reading(root, record, step, loc) for loc in (0, 1, 2))
    return rows, statistics.median(r[1] for r in rows), any(r[2] for r in rows)


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


def log_cell(value, stand_in):
    """A log K3, marked † where a last K's log stands in for it."""
    return signed(value, 3) + ("†" if stand_in else "")


def verdict(rule, difference, dimensions):
    """The protocol's verdict from the difference of medians or the three dimensions."""
    if rule == "shift":
        return "moves" if abs(difference) > MOVE else "does not move"
    if rule == "up":
        return "moves" if difference >= MOVE else "does not move"
    if rule == "dimension":
        return f"reads {statistics.median(dimensions):g}"
    return rule


def table_row(root, protocol, seed, arm, change, record, step, control, rule):
    """One arm's markdown row."""
    rows, median, stand_in = readings(root, record, step)
    dimensions = [r[0] for r in rows]
    q = hidden_q(root, record, step)
    if control is None:
        diff, judged = "—", "control"
    else:
        _, control_median, control_stand_in = readings(root, *control)
        difference = median - control_median
        diff = log_cell(difference, stand_in or control_stand_in)
        judged = verdict(rule, difference, dimensions)
    cells = [protocol, str(seed), arm, change, f"{step:,}".replace(",", " "),
             ", ".join(log_cell(r[1], r[2]) for r in rows), log_cell(median, stand_in), diff,
             ", ".join(map(str, dimensions)), "—" if q is None else signed(q, 2), judged]
    return "| " + " | ".join(cells) + " |"


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "results"
    print("| protocol | seed | arm | the one change | steps | log K3 at location seeds 0, 1, 2 "
          "| median | − control's | dimensions | Q's hidden R² | verdict |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for row in ROWS:
        print(table_row(root, *row))


if __name__ == "__main__":
    main()
