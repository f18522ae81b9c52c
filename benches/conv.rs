//! Convolution and U-Net speed (criterion; `cargo bench --bench conv`).
//!
//! Workloads and targets (PyTorch 2 threads, f32, channels-last, on the same machine; the
//! PyTorch scripts are in `benches/pytorch/`):
//! - conv 3×3 reflect, forward + backward (∂x and ∂w), (8,16,64,64)→16 ≤ 3.1 ms,
//!   (8,64,16,16)→64 ≤ 2.6 ms, (4,16,256,256)→16 ≤ 20.5 ms;
//! - U-Net 8→16/32/64→8 on (8,8,64,64): forward + MSE + backward + Adam step ≤ 37 ms.
//!
//! Backward is seeded with a fixed random cotangent handed over by [`GiveGrad`], and the clock
//! starts once `x`, `w` and the cotangent are on the tape (see [`timed`]), so the conv timings
//! hold the conv's own forward and backward.
//!
//! Each workload runs with both conv2d implementations in the same process, `gemm` (the faer
//! lowering) and `direct` (the AVX-512 micro-kernels, the default where available), so their
//! medians compare under the same machine load. The U-Net step switches every conv2d through
//! [`set_default_conv_kernel`]. Filter with e.g. `cargo bench --bench conv -- direct`.

use autodiff::learn::ParamGrads;
use autodiff::nn::unet::{UNet, UNetConfig};
use autodiff::ops::conv::{set_default_conv_kernel, Conv2d, ConvKernel, Padding};
use autodiff::optim::{Adam, Optimizer};
use autodiff::{ParamStore, Tape, Tensor};
use criterion::{criterion_group, criterion_main, Criterion};
use std::cell::RefCell;
use std::hint::black_box;
use std::time::{Duration, Instant};

mod common;
use common::{noise, GiveGrad};

fn conv(c: &mut Criterion) {
    let mut group = c.benchmark_group("conv3x3_fwd_bwd");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    let kernels = [("gemm", ConvKernel::Gemm), ("direct", ConvKernel::Direct)];
    let shapes = [
        (8, 16, 64, 16, Padding::Reflect, false),
        (8, 64, 16, 64, Padding::Reflect, false),
        (4, 16, 256, 16, Padding::Reflect, false),
        (8, 32, 32, 32, Padding::Zero, true),
    ];
    for &(b, ci, h, co, padding, relu) in &shapes {
        let x = noise(&[b, ci, h, h], 1);
        let w = noise(&[co, ci, 3, 3], 2);
        let r = noise(&[b, co, h, h], 3);
        let mut tape = Tape::<f32>::new();
        let gflop = 3.0 * 2.0 * (b * h * h * co * ci * 9) as f64 / 1e9;
        let tag = format!("{padding:?}{}", if relu { "_relu" } else { "" }).to_lowercase();
        eprintln!("conv ({b},{ci},{h},{h})→{co} {tag}: {gflop:.3} GFLOP per fwd+bwd");
        for (name, kernel) in kernels {
            let id = format!("({b},{ci},{h},{h})->{co}_{tag}/{name}");
            let op = || Conv2d::new(padding, relu).with_kernel(kernel);
            group.bench_function(id, |bench| {
                bench.iter_custom(|n| {
                    (0..n)
                        .map(|_| timed(&mut tape, &x, &w, &r, op(), "all"))
                        .sum()
                })
            });
        }
    }
    group.finish();
}

/// The three products of one conv separately (forward only; forward + `∂x`; forward + `∂w`),
/// direct kernels, to see where a fwd+bwd time goes. Filter with `-- phases`.
fn conv_phases(c: &mut Criterion) {
    let mut group = c.benchmark_group("conv3x3_phases");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    for &(b, ci, h, co) in &[(8, 16, 64, 16), (8, 64, 16, 64), (4, 16, 256, 16)] {
        let x = noise(&[b, ci, h, h], 1);
        let w = noise(&[co, ci, 3, 3], 2);
        let r = noise(&[b, co, h, h], 3);
        let mut tape = Tape::<f32>::new();
        for phase in ["fwd", "fwd+dx", "fwd+dw"] {
            let op = || Conv2d::new(Padding::Reflect, false).with_kernel(ConvKernel::Direct);
            group.bench_function(format!("({b},{ci},{h},{h})->{co}/{phase}"), |bench| {
                bench.iter_custom(|n| {
                    (0..n)
                        .map(|_| timed(&mut tape, &x, &w, &r, op(), phase))
                        .sum()
                })
            });
        }
    }
    group.finish();
}

/// One conv forward (+ backward seeded with `r`), timed from the moment `x`, `w` and the
/// cotangent are on the tape: like a PyTorch timing of `y = conv2d(x, w); y.backward(r)` with
/// `x`, `w` and `r` made beforehand, the copies that put them on the tape are not counted
/// (each is one memory pass over a tensor; in a network the input is the previous op's
/// output and the cotangent the next op's gradient, both already in place).
/// `phase`: `"fwd"` (no backward), `"fwd+dx"` (only `x` wants a gradient), `"fwd+dw"` (only
/// `w`), `"all"` (both).
fn timed(
    tape: &mut Tape<f32>,
    x: &Tensor<f32>,
    w: &Tensor<f32>,
    r: &Tensor<f32>,
    op: Conv2d,
    phase: &str,
) -> Duration {
    tape.clear();
    let xt = tape.pool().copy_of(x.shape(), x.data());
    let wt = tape.pool().copy_of(w.shape(), w.data());
    // No cotangent for a forward-only timing: one made and dropped unused would leave the
    // pool a 16 MB buffer short at 256², and the next step would allocate (and fault in) one.
    let seed = (phase != "fwd").then(|| tape.pool().copy_of(r.shape(), r.data()));
    let (xv, wv) = match phase {
        "fwd+dx" => (tape.leaf(xt), tape.constant(wt)),
        "fwd+dw" => (tape.constant(xt), tape.leaf(wt)),
        "all" => (tape.leaf(xt), tape.leaf(wt)),
        _ => (tape.constant(xt), tape.constant(wt)),
    };
    let start = Instant::now();
    let y = tape.apply(op, &[xv, wv]);
    if let Some(seed) = seed {
        let l = tape.apply(GiveGrad(RefCell::new(Some(seed))), &[y]);
        tape.backward(l);
    }
    black_box(tape.value(y).data()[0]);
    start.elapsed()
}

fn unet(c: &mut Criterion) {
    let mut group = c.benchmark_group("unet_step");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(6))
        .warm_up_time(Duration::from_secs(2));
    let mut ps = ParamStore::<f32>::new();
    let net = UNet::new(&mut ps, "d", UNetConfig::quick());
    let mut opt = Optimizer::new(Adam::default());
    let x = noise(&[8, 8, 64, 64], 4);
    let target = noise(&[8, 8, 64, 64], 5);
    let mut tape = Tape::<f32>::new();
    let mut grads = ParamGrads::new();
    for (name, kernel) in [("gemm", ConvKernel::Gemm), ("direct", ConvKernel::Auto)] {
        set_default_conv_kernel(kernel);
        group.bench_function(format!("quick_(8,8,64,64)_fwd_bwd_adam/{name}"), |bench| {
            bench.iter(|| {
                tape.clear();
                let xv = tape.constant_from(x.shape(), x.data());
                let tv = tape.constant_from(target.shape(), target.data());
                let y = net.forward(&mut tape, &ps, xv);
                let l = tape.mse(y, tv);
                tape.backward(l);
                grads.fill_from_tape(&tape);
                opt.step(1e-3, &mut ps, &grads).unwrap();
            })
        });
    }
    set_default_conv_kernel(ConvKernel::Auto);
    group.finish();
}

criterion_group!(benches, conv, conv_phases, unet);
criterion_main!(benches);
