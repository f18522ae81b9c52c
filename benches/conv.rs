//! Convolution and U-Net speed (criterion; `cargo bench --bench conv`).
//!
//! Workloads and targets (PyTorch 2 threads, f32, channels-last, on the project machine; see
//! issue 2):
//! - conv 3×3 reflect, forward + backward (∂x and ∂w), (8,16,64,64)→16 ≤ 3.1 ms,
//!   (8,64,16,16)→64 ≤ 2.6 ms, (4,16,256,256)→16 ≤ 20.5 ms;
//! - U-Net 8→16/32/64→8 on (8,8,64,64): forward + MSE + backward + Adam step ≤ 37 ms.
//!
//! Backward is seeded with a fixed random cotangent through [`InjectGrad`], a zero-cost op, so
//! the conv timings hold only the conv's own forward and backward.

use autodiff::learn::ParamGrads;
use autodiff::nn::unet::{UNet, UNetConfig};
use autodiff::ops::conv::Padding;
use autodiff::optim::{Adam, Optimizer};
use autodiff::{ParamStore, Tape};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

mod common;
use common::{noise, InjectGrad};

fn conv(c: &mut Criterion) {
    let mut group = c.benchmark_group("conv3x3_fwd_bwd");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    for &(b, ci, h, co) in &[(8, 16, 64, 16), (8, 64, 16, 64), (4, 16, 256, 16)] {
        let x = noise(&[b, ci, h, h], 1);
        let w = noise(&[co, ci, 3, 3], 2);
        let r = Arc::new(noise(&[b, co, h, h], 3));
        let mut tape = Tape::<f32>::new();
        let gflop = 3.0 * 2.0 * (b * h * h * co * ci * 9) as f64 / 1e9;
        eprintln!("conv ({b},{ci},{h},{h})→{co}: {gflop:.3} GFLOP per fwd+bwd");
        group.bench_function(format!("({b},{ci},{h},{h})->{co}"), |bench| {
            bench.iter(|| {
                tape.clear();
                let xt = tape.pool().copy_of(x.shape(), x.data());
                let wt = tape.pool().copy_of(w.shape(), w.data());
                let (xv, wv) = (tape.leaf(xt), tape.leaf(wt));
                let y = tape.conv2d(xv, wv, Padding::Reflect);
                let l = tape.apply(InjectGrad(r.clone()), &[y]);
                tape.backward(l);
                black_box(tape.grad(wv).unwrap().data()[0]);
            })
        });
    }
    group.finish();
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
    group.bench_function("quick_(8,8,64,64)_fwd_bwd_adam", |bench| {
        bench.iter(|| {
            tape.clear();
            let xv = tape.constant_from(x.shape(), x.data());
            let tv = tape.constant_from(target.shape(), target.data());
            let y = net.forward(&mut tape, &ps, xv);
            let l = tape.mse(y, tv);
            tape.backward(l);
            grads.fill_from_tape(&tape);
            opt.step(&mut ps, &grads).unwrap();
        })
    });
    group.finish();
}

criterion_group!(benches, conv, unet);
criterion_main!(benches);
