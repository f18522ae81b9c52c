"""Each record's hidden-signal figures measured again at the default count, beside the figures
its summary.json holds: per class, the held-out R² of the percept's fit to that class's own
signal at the other classes' cones (`colorvision.hidden`, docs/python.md). A record's summary
written before the count was kept holds 32 scenes from a pool of reused tiles, too few where a
class's own signal lives in rare tiles (docs/notebook/2026-12-05-hidden-signal-convergence.md).

Usage: python3 scripts/hidden-figures.py results/RECORD [results/RECORD ...]
(needs the package, `pip install ./python`, and the record's kept checkpoint)."""

import json
import sys
from pathlib import Path

import colorvision as cv


def figures(values):
    return " / ".join("—" if v is None else f"{v:.2f}" for v in values)


def main(records):
    if not records:
        sys.exit(__doc__)
    print("| record | classes | summary.json (scenes) | converged (scenes) |")
    print("|---|---|---|---|")
    for record in map(Path, records):
        summary = json.loads((record / "summary.json").read_text())
        kept = summary["invariants"]["recovery"]["hidden"]
        run = cv.load_run(str(record))
        now = cv.hidden(run.eye, run)
        print(
            f"| `{record.name}` | {'/'.join(now['classes'])} "
            f"| {figures(kept['unique_r2'])} ({kept.get('scenes') or 32}) "
            f"| {figures(now['unique_r2'])} ({now['scenes']}) |",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1:])
