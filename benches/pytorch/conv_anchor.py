"""PyTorch anchor for benches/conv.rs: conv 3x3 forward + backward (dx and dw), f32, 2 threads.

Times `y = conv(x); y.backward(r)` with x (requires_grad), w and r made beforehand, like
benches/conv.rs `timed`, for zero and reflect padding, contiguous (NCHW) and channels-last.
Prints the median of `reps` timed repetitions (after 5 untimed) per case.

Usage: conv_anchor.py [REPS [HEIGHT [LAYOUT]]]: REPS timed repetitions (default 30); only
images of that HEIGHT (64, 16 or 256) and only that LAYOUT (contiguous or channels_last) when
given.

Not part of the build or the tests. To compare in one sitting (a shared VM's speed drifts):
    python3 -m venv venv && venv/bin/pip install torch==2.15.0
    venv/bin/python benches/pytorch/conv_anchor.py 30
    cargo bench --bench conv -- "fwd_bwd/.*direct"
or, for the 256² case in alternating rounds, benches/pytorch/in_phase.sh.
"""
import sys
import torch
from timing import median_ms

torch.set_num_threads(2)
reps = int(sys.argv[1]) if len(sys.argv) > 1 else 30
height = int(sys.argv[2]) if len(sys.argv) > 2 else None
layouts = [sys.argv[3]] if len(sys.argv) > 3 else ["contiguous", "channels_last"]
shapes = [(8, 16, 64, 16), (8, 64, 16, 64), (4, 16, 256, 16)]
for (b, ci, h, co) in shapes:
    if height is not None and h != height:
        continue
    for pad in ["zeros", "reflect"]:
        for layout in layouts:
            fmt = torch.channels_last if layout == "channels_last" else torch.contiguous_format
            conv = torch.nn.Conv2d(ci, co, 3, padding=1, bias=False, padding_mode=pad)
            conv = conv.to(memory_format=fmt)
            x = torch.randn(b, ci, h, h).to(memory_format=fmt).requires_grad_(True)
            r = torch.randn(b, co, h, h).to(memory_format=fmt)

            def step():
                x.grad = None
                conv.weight.grad = None
                conv(x).backward(r)

            med = median_ms(step, reps)
            print(f"torch conv ({b},{ci},{h},{h})->{co} {pad} {layout}: median {med:.2f} ms")
            sys.stdout.flush()
