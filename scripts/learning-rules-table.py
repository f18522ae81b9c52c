#!/usr/bin/env python3
"""The table of learning rules from the sweep folders `scripts/learning-rules-table.sh` ran.

Usage: scripts/learning-rules-table.py OUT_DIR [CRITERION_DIR]   (markdown on stdout)

One row per run: the rule and what distinguishes the run (seed, feedback draw, control), then
- non-finite stops: 1 when the run ended on a non-finite loss or gradient (its `failed.json`);
- empty warp: the share of all steps whose prediction loss (`main_loss`) is exactly 0, and the
  first of them: P had moved every sampling point out of the field, the warp's mask was empty
  and the prediction error gave no gradient (docs/learning-rules.md, "The empty warp"); "—"
  when no step was;
- held-out gain: "next frame = this frame" MSE over the model's (summary.json); undefined when
  the held-out warp was empty too;
- C d′ of L, M (each to its nearest other class) and S;
- CMF-SIM: the dimension at each measurement ("d@step", 1 000s as k), then the final
  converged margins per K (worst error over threshold; < 1 passes);
- W surround r (learned 7×7 kernel's surround taps against the DoG's);
- P error: RMS position error after the affine gauge, cone spacings;
- cosine to backprop per bucket W/C/D/P: the mean of metrics.csv's align_cos_* columns, and in
  parentheses how many measurements that is (a step whose warp is empty measures nothing);
- step time relative to backprop: criterion's median of `learning_rule_step/<rule>`
  (`cargo bench --bench learning_rules`), when CRITERION_DIR holds it.
"""
import csv
import json
import os
import re
import sys


def read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def mean_cosines(metrics):
    sums, counts = [0.0] * 4, [0] * 4
    try:
        with open(metrics) as f:
            for row in csv.DictReader(f):
                for k, b in enumerate("WCDP"):
                    v = row.get(f"align_cos_{b}", "")
                    if v not in ("", None):
                        sums[k] += float(v)
                        counts[k] += 1
    except OSError:
        return "—"
    cosines = "/".join(f"{s / c:.2f}" if c else "—" for s, c in zip(sums, counts))
    return f"{cosines} ({max(counts)})" if any(counts) else cosines


def empty_warp(metrics):
    """Share of metrics.csv's steps whose loss is exactly 0 and the first such step ("—": none)."""
    try:
        with open(metrics) as f:
            losses = [(int(r["step"]), float(r["main_loss"])) for r in csv.DictReader(f)]
    except (OSError, ValueError, KeyError):
        return "—"
    empty = [s for s, l in losses if l == 0.0]
    if not empty:
        return "—"
    return f"{100 * len(empty) / len(losses):.0f} % (from {empty[0]})"


def label(config):
    rule = config.get("learning_rule", "backprop")
    settings = config.get("rule", {}) or {}
    parts = [f"seed {config.get('seed')}"]
    if "feedback_seed" in settings:
        parts.append(f"draw {settings['feedback_seed']}")
    for key in ("scheme", "flip_sign"):
        if key in settings:
            value = settings[key]
            parts.append(f"{key} {str(value).lower() if isinstance(value, bool) else value}")
    d = config.get("cortex", {}).get("train", {}).get("per_bucket", {}).get("d", {})
    if d.get("learning_rate_scale", 1.0) == 0.0:
        parts.append("D frozen")
    return rule, ", ".join(parts)


def fmt(v, digits=2):
    return "—" if v is None else f"{v:.{digits}f}"


def step_times(criterion):
    times = {}
    base = os.path.join(criterion or "", "learning_rule_step")
    if not os.path.isdir(base):
        return times
    for rule in os.listdir(base):
        e = read_json(os.path.join(base, rule, "new", "estimates.json"))
        if e:
            times[rule] = e["median"]["point_estimate"]
    return times


# How the cortex words a non-finite stop: "the gradient of `…` became non-finite" or "the loss
# became NaN" (or inf, -inf).
NON_FINITE = re.compile(r"became (non-finite|NaN|inf|-inf)\b")


def heldout_gain(heldout):
    """The held-out gain, `[model MSE, identity MSE, identity / model]`, in words: undefined when
    the held-out warp was empty too (both errors 0), in powers of ten when it is tiny."""
    if not heldout:
        return "—"
    model, identity, gain = heldout
    if model == 0 and identity == 0:
        return "undefined (empty held-out warp)"
    return f"{gain:.1e}" if 0 < gain < 0.01 else f"{gain:.2f}"


def stop_reason(error):
    """A failed run's error in a few words: the step, and for a non-finite stop the op and bucket."""
    step = re.search(r"at step (\d+)", error)
    where = re.search(r"produced by `([^`]+)` in bucket (\w+), (\w+)", error)
    if NON_FINITE.search(error) and step:
        origin = f" from `{where[1]}` ({where[2]}, {where[3]})" if where else ""
        return f"stopped at step {step[1]}: non-finite{origin}"
    return "failed: " + error[:60]


def row(run_dir, times):
    summary = read_json(os.path.join(run_dir, "summary.json"))
    failed = read_json(os.path.join(run_dir, "failed.json"))
    config = summary["config"] if summary else {}
    if not summary:
        try:
            import tomllib

            with open(os.path.join(run_dir, "config.toml"), "rb") as f:
                config = tomllib.load(f)
        except (OSError, ImportError, ValueError):
            config = {}
    rule, what = label(config)
    error = (failed or {}).get("error", "")
    non_finite = int(NON_FINITE.search(error) is not None)
    cells = [rule, what, str(non_finite), empty_warp(os.path.join(run_dir, "metrics.csv"))]
    rel = "—"
    if rule in times and "backprop" in times:
        rel = f"{times[rule] / times['backprop']:.2f}×"
    if not summary:
        return cells + [stop_reason(error) if failed else "not finished"] + ["—"] * 5 + [rel]
    gain = heldout_gain(summary.get("heldout_prediction"))
    rec = (summary.get("invariants") or {}).get("recovery") or {}
    c, w, p = rec.get("c") or {}, rec.get("w") or {}, rec.get("p") or {}
    dprime = dict(zip(c.get("classes", []), c.get("dprime", [])))
    dp = "/".join(fmt(dprime.get(k)) for k in ("L", "M", "S"))
    dims = " ".join(
        f"{d['dimension']}@{d['step'] // 1000}k" if d["step"] >= 1000 else f"{d['dimension']}@{d['step']}"
        for d in summary.get("dimension_over_steps", [])
    )
    margins = ", ".join(f"K{k} {r:.2f}" for k, r in summary.get("converged_ratio_per_k", []))
    margins = margins or "no margin (undefined)"
    return cells + [
        gain,
        dp,
        f"{dims}; {margins}",
        fmt(w.get("surround_r")),
        fmt(p.get("position_error_rms_cones")),
        mean_cosines(os.path.join(run_dir, "metrics.csv")),
        rel,
    ]


def main():
    out = sys.argv[1]
    times = step_times(sys.argv[2] if len(sys.argv) > 2 else None)
    header = [
        "rule", "run", "non-finite stops", "steps with an empty warp", "held-out gain", "C d′ L/M/S",
        "CMF-SIM dimension over steps; final margins", "W surround r", "P error (cones)",
        "cos to backprop W/C/D/P", "step time / backprop",
    ]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    order = ["seeds", "fa-draws", "dfa-draws", "d-frozen", "sign-flip"]
    sweeps = sorted(os.listdir(out), key=lambda n: (order.index(n) if n in order else len(order), n))
    for sweep in sweeps:
        manifest = read_json(os.path.join(out, sweep, "sweep.json"))
        if not manifest:
            continue
        for task in manifest["tasks"]:
            cells = row(os.path.join(out, sweep, task["folder"]), times)
            print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
