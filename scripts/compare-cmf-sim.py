#!/usr/bin/env python3
"""Two CMF-SIM readings of one observer side by side: the verdict, each K's converged worst
ratio (its margin) and reported curve, the shows and the seconds.

A faster way of reading must give the same verdict and every margin within a relative
tolerance of the reference's (default 1e-4); the exit status says whether it does (0: it does,
1: it does not, 2: bad input).

Usage: scripts/compare-cmf-sim.py REFERENCE/cmf_sim.json OTHER/cmf_sim.json [--rel 1e-4]
"""
import json
import sys


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"compare-cmf-sim.py: {path}: {e}")


def rel(a, b):
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    tol = 1e-4
    if "--rel" in argv:
        tol = float(argv[argv.index("--rel") + 1])
        args.remove(argv[argv.index("--rel") + 1])
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    ref, other = load(args[0]), load(args[1])
    ok = ref["dimension"] == other["dimension"]
    print(f"dimension: {ref['dimension']} / {other['dimension']}" + ("" if ok else "  DIFFERS"))
    for a, b in zip(ref["per_k"], other["per_k"]):
        ra, rb = a["converged_worst_ratio"], b["converged_worst_ratio"]
        d = rel(ra, rb)
        same = a["passed"] == b["passed"] and d <= tol
        ok &= same
        print(
            f"K{a['n_primaries']}: margin {ra:.10g} / {rb:.10g} (relative difference {d:.2e}), "
            f"passed {a['passed']} / {b['passed']}, shows {a['shows']} / {b['shows']}"
            + ("" if same else "  DIFFERS")
        )
    if len(ref["per_k"]) != len(other["per_k"]):
        ok = False
        print(f"K tried: {len(ref['per_k'])} / {len(other['per_k'])}  DIFFERS")
    worst = 0.0
    for a, b in zip(ref["curves"], other["curves"]):
        if a["primaries_nm"] != b["primaries_nm"]:
            ok = False
            print(f"K{a['n_primaries']}: reported primaries {a['primaries_nm']} / {b['primaries_nm']}  DIFFERS")
            continue
        for ea, eb, t in zip(a["errors"], b["errors"], ref["threshold"]):
            worst = max(worst, abs(ea - eb) / t)
    print(f"reported curves: largest error difference {worst:.2e} of the threshold there")
    sa, sb = ref["seconds"], other["seconds"]
    print(
        f"shows {ref['shows']} / {other['shows']} ({other['shows'] / ref['shows']:.3f}), "
        f"seconds {sa:.0f} / {sb:.0f} ({sb / sa:.3f}; speed-up {sa / sb:.2f})"
    )
    print("same verdict and margins" if ok else "NOT the same")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
