"""A PyTorch model trained on the eye's optic nerve signal, then measured with CMF-SIM.

The model learns, from the ONS alone (and the eye's shift between two frames, as a run with
`oracle_motion` does), a percept image P = f(ONS_t) of C channels such that P moved by the eye's
shift and read out by a 1x1 convolution g predicts the next frame ONS_t+1 — the paper's
self-supervised objective in miniature, with no lateral-inhibition inverse and no learned cone
positions. After a few hundred steps its colour dimensionality is measured with the same
calibrated CMF-SIM as the project's cortex.

    pip install ./python torch
    python python/examples/torch_decoder.py --steps 300
"""

import argparse
import time

import numpy as np
import torch
import torch.nn.functional as F

import colorvision as cv


class Encoder(torch.nn.Module):
    """ONS (N, 1, n, n) -> percept (N, C, n, n): two 5x5 convolutions."""

    def __init__(self, channels: int, hidden: int = 16):
        super().__init__()
        self.a = torch.nn.Conv2d(1, hidden, 5, padding=2)
        self.b = torch.nn.Conv2d(hidden, channels, 5, padding=2)

    def forward(self, ons: torch.Tensor) -> torch.Tensor:
        return self.b(torch.tanh(self.a(ons)))


def shifted(percept: torch.Tensor, shift: torch.Tensor) -> torch.Tensor:
    """The percept moved by the eye's shift: frame t+1 at x samples frame t at x + d, with d in
    field units (d / (field_px / 2)), the same units as grid_sample's [-1, 1] coordinates (the
    cone lattice is treated as uniform)."""
    n = percept.shape[0]
    theta = torch.zeros(n, 2, 3)
    theta[:, 0, 0] = theta[:, 1, 1] = 1.0
    theta[:, :, 2] = shift
    grid = F.affine_grid(theta, list(percept.shape), align_corners=False)
    return F.grid_sample(percept, grid, padding_mode="border", align_corners=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="tiny")
    parser.add_argument("--cones", default="LMS")
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--batch-size", type=int, default=16)
    parser.add_argument("--channels", type=int, default=8)
    parser.add_argument("--budget", default="full", choices=["full", "quick"])
    args = parser.parse_args()
    torch.manual_seed(0)
    torch.set_num_threads(1)

    start = time.monotonic()
    eye = cv.Eye(args.preset, cones=args.cones, seed=0)
    f = Encoder(args.channels)
    g = torch.nn.Conv2d(args.channels, 1, 1)
    optimiser = torch.optim.Adam([*f.parameters(), *g.parameters()], lr=1e-3)
    for step, (ons_t, ons_t1, shift) in enumerate(eye.batches(args.batch_size, count=args.steps), 1):
        ons_t, ons_t1, shift = map(torch.from_numpy, (ons_t, ons_t1, shift))
        prediction = g(shifted(f(ons_t[:, None]), shift))
        loss = F.mse_loss(prediction, ons_t1[:, None])
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        if step % 50 == 0 or step == 1:
            print(f"step {step:4d}: loss {loss.item():.3e} (no-change {F.mse_loss(ons_t, ons_t1).item():.3e})")
    print(f"trained {args.steps} steps in {time.monotonic() - start:.1f} s")

    @torch.no_grad()
    def decoder(ons: np.ndarray) -> np.ndarray:
        return f(torch.from_numpy(ons)[:, None]).numpy()

    t = time.monotonic()
    result = cv.cmf_sim(eye, decoder, budget=args.budget)
    print(result.summary())
    print(f"CMF-SIM in {time.monotonic() - t:.1f} s; margins {result.margins}")


if __name__ == "__main__":
    main()
