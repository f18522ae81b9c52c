"""A NumPy decoder measured end to end: learn C local filters of the optic nerve signal from the
eye's own batches (principal components of 3x3 ONS patches — a model that sees only the ONS),
then measure the colour dimensionality of "ONS -> those filters" with the calibrated CMF-SIM,
beside the oracle decoder of the same eye (the known answer: 3 for LMS).

    pip install ./python
    python python/examples/numpy_decoder.py                 # the tiny eye (32x32 cones)
    python python/examples/numpy_decoder.py --preset quick  # the quick eye (64x64 cones)
"""

import argparse
import logging
import time

import numpy as np

import colorvision as cv

FILTER_SIDE = 3


def patches(frames: np.ndarray) -> np.ndarray:
    """Every 3x3 patch of every frame (N, n, n) as rows (N * (n-2)^2, 9)."""
    n = frames.shape[-1]
    k = FILTER_SIDE
    views = [frames[:, i : n - k + 1 + i, j : n - k + 1 + j] for i in range(k) for j in range(k)]
    return np.stack(views, axis=-1).reshape(-1, k * k)


class LocalPcaDecoder:
    """Percept channel c = the ONS filtered by the c-th principal 3x3 filter (zero-padded)."""

    def __init__(self, filters: np.ndarray):
        self.filters = filters.astype(np.float32)  # (C, 3, 3)

    @classmethod
    def fit(cls, eye: cv.Eye, channels: int, batches: int) -> "LocalPcaDecoder":
        rows = np.concatenate([patches(ons_t) for ons_t, _, _ in eye.batches(count=batches)])
        rows -= rows.mean(axis=0)
        _, _, vt = np.linalg.svd(rows, full_matrices=False)
        return cls(vt[:channels].reshape(channels, FILTER_SIDE, FILTER_SIDE))

    def __call__(self, ons: np.ndarray) -> np.ndarray:
        """(N, n, n) float32 -> (N, C, n, n) float32."""
        n = ons.shape[-1]
        padded = np.pad(ons, ((0, 0), (1, 1), (1, 1)))
        out = np.zeros((ons.shape[0], len(self.filters), n, n), dtype=np.float32)
        for c, f in enumerate(self.filters):
            for i in range(FILTER_SIDE):
                for j in range(FILTER_SIDE):
                    out[:, c] += f[i, j] * padded[:, i : i + n, j : j + n]
        return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="tiny")
    parser.add_argument("--cones", default="LMS")
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--batches", type=int, default=20)
    parser.add_argument("--budget", default="full", choices=["full", "quick"])
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)

    start = time.monotonic()
    eye = cv.Eye(args.preset, cones=args.cones, seed=0)
    print(eye)
    decoder = LocalPcaDecoder.fit(eye, args.channels, args.batches)
    print(f"fitted {args.channels} local filters on {args.batches} batches in {time.monotonic() - start:.1f} s")

    for name, d in [("local PCA filters (NumPy)", decoder), ("oracle (known answer)", cv.oracle())]:
        t = time.monotonic()
        result = cv.cmf_sim(eye, d, budget=args.budget)
        margins = ", ".join(f"K={k}: {m:.2f}" for k, m in result.margins.items())
        print(f"{name}: dimension {result.dimension} — {result.verdict}")
        print(f"  base/energy {result.base_over_energy:.3f}; margins (< 1 passes) {margins}; {time.monotonic() - t:.1f} s")
    print(f"total {time.monotonic() - start:.1f} s")


if __name__ == "__main__":
    main()
