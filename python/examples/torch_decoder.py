"""A PyTorch model trained on the eye's optic nerve signal, then measured with CMF-SIM.

The model learns, from the ONS alone (and the eye's shift between two frames, as a run with
`oracle_motion` does), a percept image P = f(ONS_t) of C channels such that P moved by the eye's
shift and read by each cone with its own learned weights, then one lateral kernel, predicts the
next frame ONS_t+1 — the paper's self-supervised objective in miniature, with no
lateral-inhibition inverse and no learned cone positions. Then its colour dimensionality is
measured with the same calibrated CMF-SIM as the project's cortex (measured: 1-D after 2 000
steps on the tiny LMS eye, about a minute; docs/python.md).

    pip install ./python torch
    python python/examples/torch_decoder.py --steps 2000
"""

import argparse
import time

import numpy as np
import torch
import torch.nn.functional as F

import colorvision as cv


class Encoder(torch.nn.Module):
    """ONS (N, 1, n, n) -> percept (N, C, n, n): two 5x5 convolutions over the ONS and a learned
    code per cone (`code_channels` numbers at each of the n x n places). A convolution alone is
    the same at every place, so it cannot tell which kind of cone sits where in a random mosaic;
    the code is where the model can learn it, from the ONS alone."""

    def __init__(self, side: int, channels: int, hidden: int = 16, code_channels: int = 4):
        super().__init__()
        self.code = torch.nn.Parameter(torch.zeros(1, code_channels, side, side))
        self.a = torch.nn.Conv2d(1 + code_channels, hidden, 5, padding=2)
        self.b = torch.nn.Conv2d(hidden, channels, 5, padding=2)

    def forward(self, ons: torch.Tensor) -> torch.Tensor:
        code = self.code.expand(ons.shape[0], -1, -1, -1)
        return self.b(torch.tanh(self.a(torch.cat([ons, code], dim=1))))


class Cones(torch.nn.Module):
    """Percept (N, C, n, n) -> predicted ONS (N, 1, n, n): each place reads the percept with its
    own C weights (what the model learns of that cone's sensitivity), then one 5x5 kernel for
    the lateral inhibition. A readout that is the same at every place would not need the
    percept to carry colour at all: one number per place would predict as well."""

    def __init__(self, side: int, channels: int):
        super().__init__()
        self.weights = torch.nn.Parameter(0.1 * torch.randn(1, channels, side, side))
        self.lateral = torch.nn.Conv2d(1, 1, 5, padding=2)

    def forward(self, percept: torch.Tensor) -> torch.Tensor:
        return self.lateral((percept * self.weights).sum(dim=1, keepdim=True))


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
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--batch-size", type=int, default=16)
    parser.add_argument("--channels", type=int, default=8)
    parser.add_argument("--budget", default="full", choices=["full", "quick"])
    args = parser.parse_args()
    torch.manual_seed(0)
    torch.set_num_threads(1)

    start = time.monotonic()
    eye = cv.Eye(args.preset, cones=args.cones, seed=0)
    f = Encoder(eye.n_cones, args.channels)
    g = Cones(eye.n_cones, args.channels)
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
