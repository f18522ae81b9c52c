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
//! The `ceiling` group measures the machine's f32 ceiling in the same run: independent chains
//! of fused multiply-adds on 16-lane vectors (AVX-512F, else 8-lane AVX2 + FMA), nothing read
//! or written, on one thread and on two; its throughput reads as GFLOP/s. The conv groups run
//! on `RAYON_NUM_THREADS` threads: compare them with the ceiling row of the same count.
//! `conv3x3_phases` times each 3×3 layer shape of the quick U-Net (and the paper's first)
//! forward, forward + `∂x`, forward + `∂w` and forward + both, with its throughput in GFLOP/s
//! too (`2·B·Cin·Cout·9·H·W` a pass, one more pass for each gradient), so
//! `cargo bench --bench conv -- "ceiling|phases"` gives each layer's share of the ceiling from
//! one run.
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
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
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

/// Each 3×3 layer shape of the quick U-Net (16/32/64 on 64², input 8 channels) and the paper
/// eye's first one, forward only, forward + `∂x`, forward + `∂w` and forward + both, direct
/// kernels, with its throughput in GFLOP/s. Filter with `-- phases`.
fn conv_phases(c: &mut Criterion) {
    let mut group = c.benchmark_group("conv3x3_phases");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    let shapes = [
        (8, 8, 64, 16),
        (8, 16, 64, 16),
        (8, 16, 32, 32),
        (8, 32, 32, 32),
        (8, 32, 16, 64),
        (8, 64, 16, 64),
        (8, 64, 32, 32),
        (8, 32, 64, 16),
        (4, 16, 256, 16),
    ];
    for &(b, ci, h, co) in &shapes {
        let x = noise(&[b, ci, h, h], 1);
        let w = noise(&[co, ci, 3, 3], 2);
        let r = noise(&[b, co, h, h], 3);
        let mut tape = Tape::<f32>::new();
        let pass_flop = 2 * b * ci * co * 9 * h * h;
        for (phase, passes) in [("fwd", 1), ("fwd+dx", 2), ("fwd+dw", 2), ("all", 3)] {
            group.throughput(Throughput::Elements((pass_flop * passes) as u64));
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

/// Rounds of 16 vector fused multiply-adds per call of [`fma_chains`].
const FMA_ROUNDS: usize = 200_000;

/// `FMA_ROUNDS` rounds of 16 vector fused multiply-adds on independent chains, enough of them
/// to hide the FMA latency.
fn fma_chains() {
    fma_chains_of(fma_lanes())
}

/// [`fma_chains`] on `lanes`-wide vectors (16: AVX-512F, 8: AVX2 + FMA; any other, or wider
/// than this CPU runs: nothing).
fn fma_chains_of(lanes: usize) {
    if lanes > fma_lanes() {
        return;
    }
    match lanes {
        // SAFETY (both): `fma_lanes` says the CPU runs vectors this wide, and every CPU it
        // counts at 16 lanes has AVX2 and FMA too.
        #[cfg(target_arch = "x86_64")]
        16 => unsafe { fma_chains_avx512() },
        #[cfg(target_arch = "x86_64")]
        8 => unsafe { fma_chains_avx2() },
        _ => {}
    }
}

/// Lanes of the widest FMA this CPU runs: 16 (AVX-512F), 8 (AVX2 + FMA) or 0 (neither).
fn fma_lanes() -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            return if is_x86_feature_detected!("avx512f") {
                16
            } else {
                8
            };
        }
    }
    0
}

/// `FMA_ROUNDS` rounds of 16 fused multiply-adds on 16 zmm accumulators (`zmm0..zmm15`
/// ← `zmm0..zmm15 · zmm16 + zmm17`, all zeros: no denormals), written in assembly so that each
/// chain keeps its register (compiled from intrinsics, the accumulators were shuffled and
/// spilled) and the work cannot be removed.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn fma_chains_avx512() {
    std::arch::asm!(
        "vpxord zmm16, zmm16, zmm16",
        "vpxord zmm17, zmm17, zmm17",
        "vpxord zmm0, zmm0, zmm0", "vpxord zmm1, zmm1, zmm1", "vpxord zmm2, zmm2, zmm2",
        "vpxord zmm3, zmm3, zmm3", "vpxord zmm4, zmm4, zmm4", "vpxord zmm5, zmm5, zmm5",
        "vpxord zmm6, zmm6, zmm6", "vpxord zmm7, zmm7, zmm7", "vpxord zmm8, zmm8, zmm8",
        "vpxord zmm9, zmm9, zmm9", "vpxord zmm10, zmm10, zmm10", "vpxord zmm11, zmm11, zmm11",
        "vpxord zmm12, zmm12, zmm12", "vpxord zmm13, zmm13, zmm13",
        "vpxord zmm14, zmm14, zmm14", "vpxord zmm15, zmm15, zmm15",
        "2:",
        "vfmadd213ps zmm0, zmm16, zmm17", "vfmadd213ps zmm1, zmm16, zmm17",
        "vfmadd213ps zmm2, zmm16, zmm17", "vfmadd213ps zmm3, zmm16, zmm17",
        "vfmadd213ps zmm4, zmm16, zmm17", "vfmadd213ps zmm5, zmm16, zmm17",
        "vfmadd213ps zmm6, zmm16, zmm17", "vfmadd213ps zmm7, zmm16, zmm17",
        "vfmadd213ps zmm8, zmm16, zmm17", "vfmadd213ps zmm9, zmm16, zmm17",
        "vfmadd213ps zmm10, zmm16, zmm17", "vfmadd213ps zmm11, zmm16, zmm17",
        "vfmadd213ps zmm12, zmm16, zmm17", "vfmadd213ps zmm13, zmm16, zmm17",
        "vfmadd213ps zmm14, zmm16, zmm17", "vfmadd213ps zmm15, zmm16, zmm17",
        "dec {n}",
        "jnz 2b",
        n = inout(reg) FMA_ROUNDS => _,
        out("zmm0") _, out("zmm1") _, out("zmm2") _, out("zmm3") _, out("zmm4") _,
        out("zmm5") _, out("zmm6") _, out("zmm7") _, out("zmm8") _, out("zmm9") _,
        out("zmm10") _, out("zmm11") _, out("zmm12") _, out("zmm13") _, out("zmm14") _,
        out("zmm15") _, out("zmm16") _, out("zmm17") _,
        options(nostack, nomem),
    );
}

/// The same with 8-lane vectors: 14 ymm accumulators (`ymm0..ymm13` ← `· ymm14 + ymm15`), as
/// many chains as AVX2's 16 registers leave, `FMA_ROUNDS` rounds of 16 FMAs (two chains take
/// two each).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fma_chains_avx2() {
    std::arch::asm!(
        "vxorps ymm14, ymm14, ymm14",
        "vxorps ymm15, ymm15, ymm15",
        "vxorps ymm0, ymm0, ymm0", "vxorps ymm1, ymm1, ymm1", "vxorps ymm2, ymm2, ymm2",
        "vxorps ymm3, ymm3, ymm3", "vxorps ymm4, ymm4, ymm4", "vxorps ymm5, ymm5, ymm5",
        "vxorps ymm6, ymm6, ymm6", "vxorps ymm7, ymm7, ymm7", "vxorps ymm8, ymm8, ymm8",
        "vxorps ymm9, ymm9, ymm9", "vxorps ymm10, ymm10, ymm10", "vxorps ymm11, ymm11, ymm11",
        "vxorps ymm12, ymm12, ymm12", "vxorps ymm13, ymm13, ymm13",
        "2:",
        "vfmadd213ps ymm0, ymm14, ymm15", "vfmadd213ps ymm1, ymm14, ymm15",
        "vfmadd213ps ymm2, ymm14, ymm15", "vfmadd213ps ymm3, ymm14, ymm15",
        "vfmadd213ps ymm4, ymm14, ymm15", "vfmadd213ps ymm5, ymm14, ymm15",
        "vfmadd213ps ymm6, ymm14, ymm15", "vfmadd213ps ymm7, ymm14, ymm15",
        "vfmadd213ps ymm8, ymm14, ymm15", "vfmadd213ps ymm9, ymm14, ymm15",
        "vfmadd213ps ymm10, ymm14, ymm15", "vfmadd213ps ymm11, ymm14, ymm15",
        "vfmadd213ps ymm12, ymm14, ymm15", "vfmadd213ps ymm13, ymm14, ymm15",
        "vfmadd213ps ymm0, ymm14, ymm15", "vfmadd213ps ymm1, ymm14, ymm15",
        "dec {n}",
        "jnz 2b",
        n = inout(reg) FMA_ROUNDS => _,
        out("ymm0") _, out("ymm1") _, out("ymm2") _, out("ymm3") _, out("ymm4") _,
        out("ymm5") _, out("ymm6") _, out("ymm7") _, out("ymm8") _, out("ymm9") _,
        out("ymm10") _, out("ymm11") _, out("ymm12") _, out("ymm13") _, out("ymm14") _,
        out("ymm15") _,
        options(nostack, nomem),
    );
}

/// The f32 ceiling: [`fma_chains`] on one thread (the widest vectors, then 8-lane AVX2 for
/// comparison) and on two at once, throughput in GFLOP/s (an FMA is two). Without AVX2 + FMA
/// it measures nothing.
fn ceiling(c: &mut Criterion) {
    let mut group = c.benchmark_group("ceiling");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    let lanes = fma_lanes();
    let flop = (2 * 16 * lanes * FMA_ROUNDS) as u64;
    group.throughput(Throughput::Elements(flop));
    group.bench_function("f32_fma/1_thread", |b| b.iter(fma_chains));
    group.throughput(Throughput::Elements((2 * 16 * 8 * FMA_ROUNDS) as u64));
    group.bench_function("f32_fma/avx2_1_thread", |b| {
        b.iter(|| fma_chains_of(8.min(fma_lanes())))
    });
    group.throughput(Throughput::Elements(2 * flop));
    // On a pool of its own whose two workers already sit on both cores (a thread spawned per
    // call starts on its parent's core and is moved only after milliseconds), whatever
    // `RAYON_NUM_THREADS` says.
    let pair = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a pool of two threads");
    group.bench_function("f32_fma/2_threads", |b| {
        b.iter(|| pair.join(fma_chains, fma_chains))
    });
    group.finish();
}

criterion_group!(benches, conv, conv_phases, unet, ceiling);
criterion_main!(benches);
