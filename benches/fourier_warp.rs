//! Fourier filtering, grid sampling and flow speed (criterion; `cargo bench --bench fourier_warp`).
//!
//! Workloads and targets (PyTorch 2 threads, f32, on the same machine):
//! - FFT kernel multiply, forward + backward to the image and the response: real image
//!   `(8, n, n)` → FFT → `complex_mul` by a learned `(n, n, 2)` response → inverse FFT → real
//!   part; n = 64 ≤ 0.77 ms, n = 256 ≤ 6.1 ms. Two variants: "real" (`fft2_real`,
//!   `ifft2_real`, what `fft_convolve_same` uses) and "complex" (`to_complex`, `fft2`, `ifft2`,
//!   `real_part`).
//! - Bilinear grid sample, forward + backward to the image and the grid:
//!   `(8, 8, 64, 64)` ≤ 2.8 ms, `(4, 8, 256, 256)` ≤ 39 ms, with a smooth warp that pushes
//!   some samples past the border.
//! - No target, for the cortex budget: the RealNVP cell-position flow (8 blocks, MLP 1→16→16→2)
//!   on all 64² pixel coordinates, forward then inverse (the warp, docs/references.md#warp), plus backward.
//!
//! Backward is seeded with a fixed random cotangent through [`InjectGrad`], a zero-cost op, so
//! the timings hold only the measured ops' own forward and backward.

use autodiff::nn::realnvp::{RealNvp, RealNvpConfig};
use autodiff::{ParamStore, Tape, Tensor};
use criterion::{criterion_group, criterion_main, Criterion};
use rand::rngs::StdRng;
use rand::SeedableRng;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

mod common;
use common::{noise, InjectGrad};

fn fft_filter(c: &mut Criterion) {
    let mut group = c.benchmark_group("fft_kernel_multiply_fwd_bwd");
    group
        .sample_size(40)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    for &n in &[64usize, 256] {
        let b = 8;
        let x = noise(&[b, n, n], 1);
        let resp = noise(&[n, n, 2], 2);
        let r = Arc::new(noise(&[b, n, n], 3));
        let mut tape = Tape::<f32>::new();
        for real in [true, false] {
            let name = if real { "real" } else { "complex" };
            group.bench_function(format!("8x{n}^2 {name}"), |bench| {
                bench.iter(|| {
                    tape.clear();
                    let xt = tape.pool().copy_of(x.shape(), x.data());
                    let rt = tape.pool().copy_of(resp.shape(), resp.data());
                    let (xv, rv) = (tape.leaf(xt), tape.leaf(rt));
                    let y = if real {
                        let f = tape.fft2_real(xv);
                        let g = tape.complex_mul(f, rv);
                        tape.ifft2_real(g)
                    } else {
                        let c = tape.to_complex(xv);
                        let f = tape.fft2(c);
                        let g = tape.complex_mul(f, rv);
                        let y = tape.ifft2(g);
                        tape.real_part(y)
                    };
                    let l = tape.apply(InjectGrad(r.clone()), &[y]);
                    tape.backward(l);
                    black_box(tape.grad(rv).unwrap().data()[0]);
                    black_box(tape.grad(xv).unwrap().data()[0]);
                })
            });
        }
    }
    group.finish();
}

/// A smooth warp: identity, a rotation by 0.1 rad, a zoom of 1.1 and a ripple, so samples land
/// between pixels and about 10 % of them fall outside the image.
fn warp_grid(b: usize, h: usize, w: usize) -> Tensor<f32> {
    Tensor::from_fn([b, h, w, 2], |i| {
        let p = (i / 2) % (h * w);
        let k = (i / 2 / (h * w)) as f32;
        let (y, x) = (p / w, p % w);
        let (u, v) = (
            2.0 * x as f32 / (w - 1) as f32 - 1.0,
            2.0 * y as f32 / (h - 1) as f32 - 1.0,
        );
        let (s, c) = (0.1f32 + 0.01 * k).sin_cos();
        let ripple = 0.02 * (7.0 * u + 5.0 * v).sin();
        if i % 2 == 0 {
            1.1 * (c * u - s * v) + ripple
        } else {
            1.1 * (s * u + c * v) - ripple
        }
    })
}

fn grid_sample(c: &mut Criterion) {
    let mut group = c.benchmark_group("grid_sample_fwd_bwd");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    for &(b, ch, n) in &[(8usize, 8usize, 64usize), (4, 8, 256)] {
        let img = noise(&[b, ch, n, n], 4);
        let grid = warp_grid(b, n, n);
        let r = Arc::new(noise(&[b, ch, n, n], 5));
        let mut tape = Tape::<f32>::new();
        group.bench_function(format!("({b},{ch},{n},{n})"), |bench| {
            bench.iter(|| {
                tape.clear();
                let it = tape.pool().copy_of(img.shape(), img.data());
                let gt = tape.pool().copy_of(grid.shape(), grid.data());
                let (iv, gv) = (tape.leaf(it), tape.leaf(gt));
                let y = tape.grid_sample(iv, gv);
                let l = tape.apply(InjectGrad(r.clone()), &[y]);
                tape.backward(l);
                black_box(tape.grad(gv).unwrap().data()[0]);
                black_box(tape.grad(iv).unwrap().data()[0]);
            })
        });
    }
    group.finish();
}

fn realnvp(c: &mut Criterion) {
    let mut group = c.benchmark_group("realnvp_fwd_inv_bwd");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    let n = 64;
    let mut store = ParamStore::<f32>::new();
    let flow = RealNvp::new(
        &mut store,
        "p",
        RealNvpConfig::default(),
        &mut StdRng::seed_from_u64(6),
    );
    // Non-zero last layers, so the flow is not the identity.
    for ids in flow.param_ids().chunks(6) {
        for &id in &ids[4..] {
            let len = store.get(id).numel();
            let t = noise(&[len], id.0 as u64);
            store.get_mut(id).data_mut().copy_from_slice(t.data());
        }
    }
    let uv = Tensor::from_fn([n * n, 2], |i| {
        let p = i / 2;
        let q = if i % 2 == 0 { p % n } else { p / n };
        2.0 * q as f32 / (n - 1) as f32 - 1.0
    });
    let r = Arc::new(noise(&[n * n, 2], 7));
    let mut tape = Tape::<f32>::new();
    group.bench_function(format!("{n}x{n} points"), |bench| {
        bench.iter(|| {
            tape.clear();
            let vars = flow.record(&mut tape, &store);
            let pts = tape.constant_from(uv.shape(), uv.data());
            let xy = flow.forward_with(&mut tape, &vars, pts);
            let back = flow.inverse_with(&mut tape, &vars, xy);
            let l = tape.apply(InjectGrad(r.clone()), &[back]);
            tape.backward(l);
            black_box(tape.value(back).data()[0]);
        })
    });
    group.finish();
}

criterion_group!(benches, fft_filter, grid_sample, realnvp);
criterion_main!(benches);
