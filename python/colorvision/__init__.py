"""colorvision from Python: simulate the eye, feed its optic nerve signal (ONS) to your own
model, and measure that model's colour dimensionality with the calibrated CMF-SIM.

    import colorvision as cv
    eye = cv.Eye("quick", cones="LMS", seed=0)
    for ons_t, ons_t1, shift in eye.batches(batch_size=16, count=300):
        ...                                   # train a model on (N, n, n) float32 frames
    result = cv.cmf_sim(eye, my_decoder)      # my_decoder: (N, n, n) -> (N, C, n, n)
    print(result.dimension, result.margins)
    print(cv.hidden(eye, my_decoder)["unique_r2"])   # each class's own signal it carries

Conventions (docs/python.md):

- An ONS frame is ``(n, n)`` float32 on the cone lattice: row = lattice row (top to
  bottom), column = lattice column (left to right). A batch is ``(N, n, n)``.
- A percept batch is ``(N, C, n, n)`` float32, C channels on the same lattice; every value
  must be finite.
- Positions are field pixels ``[x, y]``, x right, y down, the field's top-left at (0, 0);
  an eye shift is ``[dx, dy] / (field_px / 2)`` (frame t+1 samples the scene at x + d).
- ``eye.truth`` (cone classes, weights, positions) is for evaluation only: a model must
  learn from the ONS (and, where a run asks, the shift) alone.

Rust works with the GIL released; a Python decoder and progress callback are called on the
calling thread only; Ctrl-C raises KeyboardInterrupt within about a second; bad settings,
arrays or run folders raise ValueError with the command line's message.
"""

import logging

from ._native import (
    Batches,
    CmfSimResult,
    Eye,
    KnownDecoder,
    Run,
    __version__,
    cmf_sim,
    hidden,
    load_run,
    own_image,
)

logging.getLogger("colorvision").addHandler(logging.NullHandler())

__all__ = [
    "Batches",
    "CmfSimResult",
    "Eye",
    "KnownDecoder",
    "Run",
    "__version__",
    "cmf_sim",
    "hidden",
    "own_image",
    "identity",
    "cone_activations",
    "oracle",
    "load_run",
]


def identity() -> KnownDecoder:
    """The ONS itself as the percept (no colour constancy: dimension undefined, 0)."""
    return KnownDecoder("identity")


def cone_activations() -> KnownDecoder:
    """The cone activations before lateral inhibition as the percept (dimension 1)."""
    return KnownDecoder("cones")


def oracle(interpolate: bool = True) -> KnownDecoder:
    """The oracle decoder built from the eye's truth: each kind of cone interpolated across
    the mosaic (as many dimensions as independent kinds: 3 for LMS, 2 for a dichromat), or,
    with ``interpolate=False``, each cell keeping its own kind."""
    return KnownDecoder("oracle" if interpolate else "oracle-mosaic")
