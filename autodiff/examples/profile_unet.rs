//! Where a U-Net training step goes, op by op: the quick demosaicker (8 → 16/32/64 → 8) on a
//! batch of 8 random 64 × 64 images, forward + MSE + backward + Adam, profiled with
//! [`Tape::set_profiling`]. `cargo run --release -p autodiff --example profile_unet [steps]`.
//!
//! Prints the per-op table (milliseconds per step, averaged over the timed steps) and the
//! step's wall time, so the table's share of the step is visible.

use autodiff::learn::ParamGrads;
use autodiff::nn::unet::{UNet, UNetConfig};
use autodiff::optim::{Adam, Optimizer};
use autodiff::{ParamStore, Tape, Tensor};

fn main() {
    let steps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let mut ps = ParamStore::<f32>::new();
    let net = UNet::new(&mut ps, "d", UNetConfig::quick());
    let mut opt = Optimizer::new(Adam::default());
    let mut seed = 1u64;
    let mut noise = |shape: &[usize]| {
        Tensor::<f32>::from_fn(shape, |_| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        })
    };
    let (x, target) = (noise(&[8, 8, 64, 64]), noise(&[8, 8, 64, 64]));
    let mut tape = Tape::<f32>::new();
    let mut grads = ParamGrads::new();
    let mut step = |tape: &mut Tape<f32>| {
        tape.clear();
        let xv = tape.constant_from(x.shape(), x.data());
        let tv = tape.constant_from(target.shape(), target.data());
        let y = net.forward(tape, &ps, xv);
        let l = tape.mse(y, tv);
        tape.backward(l);
        grads.fill_from_tape(tape);
        opt.step(1e-3, &mut ps, &grads).expect("finite gradients");
    };
    for _ in 0..3 {
        step(&mut tape);
    }
    tape.set_profiling(true);
    let start = std::time::Instant::now();
    for _ in 0..steps {
        step(&mut tape);
    }
    let wall_ms = start.elapsed().as_secs_f64() * 1e3 / steps as f64;
    let profile = tape.take_profile();
    println!("U-Net quick step, (8, 8, 64, 64), {steps} steps, per step:");
    println!("{}", profile.scaled(1.0 / steps as f64));
    println!("wall time per step (incl. Adam and copies): {wall_ms:.2} ms");
}
