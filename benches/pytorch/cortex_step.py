"""PyTorch port of one whole cortex training step, as `cargo bench --bench cortex_step` times it
with the oracle motion: the same shapes and ops (cortex/src/model.rs), f32, 2 threads.

- W (cortex/src/buckets/w.rs): a free complex response on the (2n-1)^2 zero-padded grid,
  identity at start; decode is the guarded inverse X conj(W) / (|W|^2 + 1e-6), encode the
  forward filter; full complex FFTs of the padded grid, the real part kept.
- C (c.rs): raw (1, N, n, n), channel 0 = 1 at start, normalised over channels (eps 1e-5);
  inject pa * C, sample sum_N V * C.
- D: the U-Net N -> widths -> N (unet.py); quick 16/32/64, paper 16/32/64/128.
- P (p.rs, autodiff/src/nn/realnvp.rs): RealNVP on 2-D points, 8 affine couplings, MLP
  1 -> 16 -> 16 -> 2 (last layer zero), log-scale a*tanh(s/a), a = 2; the warp samples the
  percept at P^-1(P(uv) + d) (bilinear, zeros outside, align-corners) and the mask is the
  nearest sample of ones there.
- Loss (docs/references.md#loss): border 3 px, sum_pixels sum_batch m (O^ - O)^2 / (sum_batch m + 1).
- Adam, lr 1e-3.
The batch is synthetic (random ONS pairs and motions), made once, as the Rust bench's paper case;
the cost does not depend on the data. D runs in the layout asked (contiguous NCHW or
channels-last); W's FFTs and P on their own. Where the port does more than ours, said plainly:
its inverse FFT is a full complex one whose real part is kept (ours returns the real part
directly), |W|^2 goes through a square root, each coupling is about ten autograd ops (ours one
fused op), and the mask is a grid_sample of ones (ours computes it directly).

Usage: cortex_step.py [REPS [quick|paper [contiguous|channels_last]]]: prints one line per
case, "torch cortex step PRESET LAYOUT: median M ms". Not part of the build or the tests; see
whole_step.sh for the interleaved comparison with ours.
"""
import sys
import torch, torch.nn as nn, torch.nn.functional as F
from timing import median_ms
from unet import UNet

torch.set_num_threads(2)
PRESETS = {"quick": (64, (16, 32, 64)), "paper": (256, (16, 32, 64, 128))}
CHANNELS, BATCH, BORDER, GUARD, BOUND = 8, 8, 3, 1e-6, 2.0


class Coupling(nn.Module):
    def __init__(s, kept, hidden=16):
        super().__init__()
        s.kept = kept
        s.mlp = nn.Sequential(nn.Linear(1, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU(),
                              nn.Linear(hidden, 2))
        nn.init.zeros_(s.mlp[4].weight)
        nn.init.zeros_(s.mlp[4].bias)

    def ts(s, p):
        h = s.mlp(p[:, s.kept:s.kept + 1])
        return h[:, 0], BOUND * torch.tanh(h[:, 1] / BOUND)

    def forward(s, p, inverse=False):
        t, log_s = s.ts(p)
        o = p[:, 1 - s.kept]
        o = (o - t) * torch.exp(-log_s) if inverse else o * torch.exp(log_s) + t
        cols = [p[:, s.kept], o] if s.kept == 0 else [o, p[:, s.kept]]
        return torch.stack(cols, 1)


class Cortex(nn.Module):
    def __init__(s, n, widths, layout):
        super().__init__()
        s.n, s.fmt = n, layout
        m = 2 * n - 1
        delta = torch.zeros(m, m)
        delta[n - 1, n - 1] = 1.0
        s.w = nn.Parameter(torch.view_as_real(torch.fft.fft2(delta)).contiguous())
        raw = torch.zeros(1, CHANNELS, n, n)
        raw[:, 0] = 1.0
        s.c = nn.Parameter(raw)
        s.d = UNet(CHANNELS, widths, CHANNELS).to(memory_format=layout)
        s.p = nn.ModuleList([Coupling(k % 2) for k in range(8)])
        u = torch.linspace(-1.0, 1.0, n)
        gy, gx = torch.meshgrid(u, u, indexing="ij")
        s.register_buffer("uv", torch.stack([gx.flatten(), gy.flatten()], 1))

    def filter(s, x, inverse):
        """Encode: x at (0, 0) of the grid, the window at (n-1, n-1); decode: the mirror
        (autodiff/src/ops/fourier/convolve.rs), so the identity response gives x / (1 + eps)."""
        n = s.n
        w = torch.view_as_complex(s.w)
        if inverse:
            spec = torch.fft.fft2(F.pad(x, (n - 1, 0, n - 1, 0)))
            return torch.fft.ifft2(spec * w.conj() / (w.abs() ** 2 + GUARD)).real[..., :n, :n]
        spec = torch.fft.fft2(F.pad(x, (0, n - 1, 0, n - 1)))
        return torch.fft.ifft2(spec * w).real[..., n - 1:, n - 1:]

    def flow(s, p, inverse=False):
        for block in (reversed(s.p) if inverse else s.p):
            p = block(p, inverse)
        return p

    def loss(s, o1, o2, motion):
        b, n = o1.shape[0], s.n
        c = s.c / (s.c.pow(2).sum(1, keepdim=True).sqrt() + 1e-5)
        x = (s.filter(o1, True) * c).contiguous(memory_format=s.fmt)
        v = s.d(x)
        xy = s.flow(s.uv)
        moved = (xy[None] + motion[:, None, :]).reshape(-1, 2)
        grid = s.flow(moved, inverse=True).reshape(b, n, n, 2)
        warped = F.grid_sample(v, grid, mode="bilinear", padding_mode="zeros", align_corners=True)
        with torch.no_grad():
            mask = F.grid_sample(torch.ones(b, 1, n, n), grid, mode="nearest", align_corners=True)
        pred = s.filter((warped * c).sum(1, keepdim=True), False)
        k = slice(BORDER, n - BORDER)
        m = mask[..., k, k]
        err = m * (pred[..., k, k] - o2[..., k, k]) ** 2
        return (err.sum(0) / (m.sum(0) + 1.0)).sum()


def case(preset, layout_name, reps):
    n, widths = PRESETS[preset]
    layout = torch.channels_last if layout_name == "channels_last" else torch.contiguous_format
    torch.manual_seed(0)
    model = Cortex(n, widths, layout)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3)
    o1, o2 = torch.rand(BATCH, 1, n, n), torch.rand(BATCH, 1, n, n)
    motion = 0.05 * torch.randn(BATCH, 2)

    def step():
        opt.zero_grad(set_to_none=True)
        model.loss(o1, o2, motion).backward()
        opt.step()

    med = median_ms(step, reps)
    print(f"torch cortex step {preset} {layout_name}: median {med:.1f} ms")
    sys.stdout.flush()


reps = int(sys.argv[1]) if len(sys.argv) > 1 else 20
presets = [sys.argv[2]] if len(sys.argv) > 2 else ["quick", "paper"]
layouts = [sys.argv[3]] if len(sys.argv) > 3 else ["contiguous", "channels_last"]
for preset in presets:
    for layout_name in layouts:
        case(preset, layout_name, reps)
