"""PyTorch anchor for benches/conv.rs unet_step: the quick U-Net 8 -> 16/32/64 -> 8 on (8,8,64,64),
bias-free reflect-padded 3x3 convs + ReLU, max-pool, transposed-conv 2x2 up (with bias), skip
concat, 1x1 out conv with bias; forward + MSE + backward + Adam step, f32, 2 threads,
contiguous (NCHW) and channels-last.
Prints the median of `reps` steps (after 5 untimed). Run beside
`cargo bench --bench conv -- unet_step` (see conv_anchor.py for the setup)."""
import sys
import torch, torch.nn as nn
from timing import median_ms
from unet import UNet
torch.set_num_threads(2)

reps = int(sys.argv[1]) if len(sys.argv) > 1 else 30
for layout in ["contiguous", "channels_last"]:
    fmt = torch.channels_last if layout == "channels_last" else torch.contiguous_format
    net = UNet().to(memory_format=fmt)
    opt = torch.optim.Adam(net.parameters())
    x = torch.randn(8, 8, 64, 64).to(memory_format=fmt)
    t = torch.randn(8, 8, 64, 64).to(memory_format=fmt)

    def step():
        opt.zero_grad(set_to_none=True)
        nn.functional.mse_loss(net(x), t).backward()
        opt.step()

    med = median_ms(step, reps)
    print(f"torch unet quick (8,8,64,64) {layout}: median {med:.2f} ms")
    sys.stdout.flush()
