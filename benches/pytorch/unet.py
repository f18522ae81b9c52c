"""The cortex's decoder D as PyTorch modules, shared by the anchors: the U-Net N -> widths -> N,
bias-free reflect-padded 3x3 convs + ReLU, max-pool, transposed-conv 2x2 up (with bias), skip
concat, 1x1 out conv with bias (cortex/src/buckets/d.rs)."""
import torch, torch.nn as nn


def dconv(ci, co):
    return nn.Sequential(nn.Conv2d(ci, co, 3, padding=1, bias=False, padding_mode="reflect"), nn.ReLU(),
                         nn.Conv2d(co, co, 3, padding=1, bias=False, padding_mode="reflect"), nn.ReLU())

class UNet(nn.Module):
    def __init__(s, cin=8, widths=(16, 32, 64), cout=8):
        super().__init__()
        s.inc = dconv(cin, widths[0])
        s.downs = nn.ModuleList([dconv(widths[i - 1], widths[i]) for i in range(1, len(widths))])
        s.ups = nn.ModuleList([nn.ConvTranspose2d(widths[i], widths[i - 1], 2, stride=2) for i in range(len(widths) - 1, 0, -1)])
        s.upc = nn.ModuleList([dconv(2 * widths[i - 1], widths[i - 1]) for i in range(len(widths) - 1, 0, -1)])
        s.out = nn.Conv2d(widths[0], cout, 1)
    def forward(s, x):
        h = s.inc(x); skips = []
        for d in s.downs:
            skips.append(h); h = d(nn.functional.max_pool2d(h, 2))
        for u, c, sk in zip(s.ups, s.upc, reversed(skips)):
            h = c(torch.cat([sk, u(h)], 1))
        return s.out(h)
