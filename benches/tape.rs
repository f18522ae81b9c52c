//! Tape overhead and matmul speed (criterion; `cargo bench --bench tape`).
//!
//! - `tape_overhead/*`: forward + backward of a chain of `OPS_PER_CHAIN` tiny ops (scalars, or
//!   16-element vectors), cycling through `mul`, `add`, `tanh`, `relu`, with `tape.clear()` each
//!   iteration as a training loop does. The throughput line reads as ops per second:
//!   ns per op = 1e3 / (Melem/s). Target: ≤ 2 µs per op, against ~70 µs per autograd
//!   call in PyTorch.
//! - `matmul_fwd_bwd/*`: `a @ b` forward plus both input gradients through faer's GEMM, f32.
//!   The loss is `sum(a @ b)`. The throughput line counts multiply-adds: GFLOP/s = 2 × Gelem/s
//!   (three GEMMs per iteration, counted as 3·m·k·n elements).
//! - `matmul_fwd_bwd_tall/*`: the same for the tall-skinny shapes of the RealNVP flow on point
//!   sets (`x (rows, 16) @ W (16, 16)`): the weight gradient `xᵀ·dy` has an inner dimension of
//!   `rows`, which the op splits across threads (see `autodiff::ops::matmul`).
//! - `relu_fwd_bwd/8x16x64x64`: relu forward and backward on a U-Net-sized activation (f32),
//!   including the copy of the input onto the tape and of the cotangent seed.

use autodiff::{Tape, Tensor};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;

const OPS_PER_CHAIN: usize = 100;

/// A leaf holding a copy of `t` in a recycled buffer (no fresh allocation after warm-up).
fn pooled_leaf(tape: &mut Tape<f32>, t: &Tensor<f32>) -> autodiff::Var {
    let v = tape.pool().copy_of(t.shape(), t.data());
    tape.leaf(v)
}

/// One forward + backward of the chain on `tape`; returns the input gradient's first element.
fn chain(tape: &mut Tape<f32>, x0: &Tensor<f32>, c0: &Tensor<f32>) -> f32 {
    tape.clear();
    let x = pooled_leaf(tape, x0);
    let c = tape.constant_from(c0.shape(), c0.data());
    let mut y = x;
    // 4 ops per round; the final sum is the 100th op.
    for _ in 0..(OPS_PER_CHAIN - 1) / 4 {
        y = tape.mul(y, c);
        y = tape.add(y, c);
        y = tape.tanh(y);
        y = tape.relu(y);
    }
    let extra = (OPS_PER_CHAIN - 1) % 4;
    for _ in 0..extra {
        y = tape.add(y, c);
    }
    let loss = tape.sum(y);
    tape.backward(loss);
    tape.grad(x).unwrap().data()[0]
}

fn tape_overhead(c: &mut Criterion) {
    let mut group = c.benchmark_group("tape_overhead");
    group
        .sample_size(50)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    group.throughput(Throughput::Elements(OPS_PER_CHAIN as u64));
    for (label, shape) in [
        ("scalar_chain_100", &[][..]),
        ("vec16_chain_100", &[16][..]),
    ] {
        let x0 = Tensor::full(shape, 0.3f32);
        let c0 = Tensor::full(shape, 0.9f32);
        let mut tape = Tape::new();
        chain(&mut tape, &x0, &c0); // fill the buffer pool
        group.bench_function(label, |b| b.iter(|| black_box(chain(&mut tape, &x0, &c0))));
    }
    group.finish();
}

/// Forward + backward of `sum(a @ b)` for each `(m, k, n)`, in one criterion group.
fn matmul_group(
    c: &mut Criterion,
    name: &str,
    shapes: &[(usize, usize, usize)],
    samples: usize,
    seconds: u64,
) {
    let mut group = c.benchmark_group(name);
    group
        .sample_size(samples)
        .measurement_time(Duration::from_secs(seconds))
        .warm_up_time(Duration::from_secs(1));
    for &(m, k, n) in shapes {
        let a0 = Tensor::from_fn([m, k], |i| ((i * 7919) % 1000) as f32 / 1000.0 - 0.5);
        let b0 = Tensor::from_fn([k, n], |i| ((i * 104729) % 1000) as f32 / 1000.0 - 0.5);
        let mut tape = Tape::<f32>::new();
        group.throughput(Throughput::Elements(3 * (m * k * n) as u64));
        group.bench_function(format!("{m}x{k}@{k}x{n}"), |bch| {
            bch.iter(|| {
                tape.clear();
                let a = pooled_leaf(&mut tape, &a0);
                let b = pooled_leaf(&mut tape, &b0);
                let y = tape.matmul(a, b);
                let loss = tape.sum(y);
                tape.backward(loss);
                black_box(tape.grad(b).unwrap().data()[0])
            })
        });
    }
    group.finish();
}

fn matmul(c: &mut Criterion) {
    matmul_group(
        c,
        "matmul_fwd_bwd",
        &[(256, 256, 256), (32768, 16, 16), (512, 1024, 512)],
        30,
        4,
    );
}

/// Tall-skinny shapes of the RealNVP flow on point sets (quick and paper scale).
fn matmul_tall(c: &mut Criterion) {
    matmul_group(
        c,
        "matmul_fwd_bwd_tall",
        &[(32768, 16, 16), (524288, 16, 16), (524288, 1, 16)],
        10,
        3,
    );
}

fn relu(c: &mut Criterion) {
    let mut group = c.benchmark_group("relu_fwd_bwd");
    group
        .sample_size(30)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    let shape = [8, 16, 64, 64];
    let x0 = Tensor::from_fn(shape, |i| ((i * 7919) % 1000) as f32 / 1000.0 - 0.5);
    let r0 = Tensor::from_fn(shape, |i| ((i * 104729) % 1000) as f32 / 1000.0 - 0.5);
    let mut tape = Tape::<f32>::new();
    group.throughput(Throughput::Bytes((x0.numel() * 4) as u64));
    group.bench_function("8x16x64x64", |b| {
        b.iter(|| {
            tape.clear();
            let x = pooled_leaf(&mut tape, &x0);
            let y = tape.relu(x);
            let seed = tape.pool().copy_of(r0.shape(), r0.data());
            tape.backward_from(&[(y, seed)], &mut autodiff::NoHooks);
            black_box(tape.grad(x).unwrap().data()[0])
        })
    });
    group.finish();
}

criterion_group!(benches, tape_overhead, matmul, matmul_tall, relu);
criterion_main!(benches);
