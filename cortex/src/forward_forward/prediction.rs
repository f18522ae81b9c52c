//! Forward-forward's prediction objective (`[rule] objective = "prediction"`,
//! `autodiff::learn::LocalObjective::Prediction`): every layer of decode learns from its own
//! prediction of the next ONS, made through a fixed read-out of its own; no error travels
//! between layers.
//!
//! The goodness objective ([`super`]) never asks D's output to be a prediction; this one asks
//! it of every layer, by local error signals (Mostafa, Ramesh & Cauwenberghs 2018, "Deep
//! supervised learning using local errors": each layer trained through a fixed random
//! classifier of its own; Nøkland & Eidnes 2019, "Training neural networks with local error
//! signals"). For a layer with representation `h` of `O_t`, in that layer's scope:
//! 1. **read-out**: `N` percept channels at the ONS's resolution — `h` itself where it already
//!    is one (C's `X = pa·C`, D's last block, whose output is the percept `V`); else a fixed
//!    random 1×1 map `R (N × ch)`, entries `±1/√ch` drawn once per layer from its scope's name
//!    (the same at every step, kept nowhere), then nearest upsampling to `n × n`. W's `pa` (one
//!    channel) is read as it is;
//! 2. **translate and re-encode** as the global prediction does: warped through P's sampling
//!    of the true motion, sampled by C (skipped for `pa`), encoded by W;
//! 3. **local loss**: the masked squared error against `O_{t+1}`, the global loss's form.
//!
//! P's sampling, C and W's response come from their own scopes, so the scope wall of the rule
//! gives them nothing from another layer's loss: a layer's loss trains that layer alone.
//! Which parts still use a global error, said plainly: D's last block learns from the true
//! prediction error of its output (its read-out is the identity), as Mostafa's output layer
//! does; P learns from the prediction of the percept `V` through its own warp — the main
//! prediction loss's gradient in P, with D's output held (the guard, the gauge and the blurred
//! objective are not used) — because the warp is the output mapping; the
//! re-encoder's objective ([`super::record_reencode_loss`]) is the global loss's form on its
//! own copies of W and C.

use crate::buckets::p::{PBucket, Sampling};
use crate::model::{Bucket, Cortex, Prediction, BUCKET_NAMES};
use crate::rng::CortexRng;
use autodiff::{Tape, Var};

/// The fixed read-out `(N, ch, 1, 1)` of the layer of scope `scope`: entries `±1/√ch`, drawn
/// from the scope's name (FNV-1a), the same at every step.
pub(super) fn readout_weights(scope: &str, n_out: usize, ch: usize) -> Vec<f32> {
    let seed = scope.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let mut rng = CortexRng::seed_from(seed);
    let scale = 1.0 / (ch as f64).sqrt();
    (0..n_out * ch)
        .map(|_| if rng.uniform() < 0.5 { -scale } else { scale } as f32)
        .collect()
}

/// `h (B, ch, m, m)` read out to `(B, N, n, n)`: the fixed random 1×1 map, then nearest
/// upsampling by `n / m` (a power of two: D's pooling), by transposed 2×2 convolutions of the
/// identity.
pub(super) fn read_out(tape: &mut Tape<f32>, scope: &str, h: Var, n_out: usize, n: usize) -> Var {
    let (_, ch, m, _) = tape.shape(h).bchw("forward_forward::prediction::read_out");
    let r = tape.constant_from([n_out, ch, 1, 1], &readout_weights(scope, n_out, ch));
    let mut x = tape.conv2d(h, r, autodiff::ops::conv::Padding::Zero);
    let mut side_px = m;
    if side_px < n {
        let identity: Vec<f32> = (0..n_out * n_out * 4)
            .map(|i| f32::from((i / 4) / n_out == (i / 4) % n_out))
            .collect();
        let up = tape.constant_from([n_out, n_out, 2, 2], &identity);
        while side_px < n {
            x = tape.conv_transpose2x2(x, up);
            side_px *= 2;
        }
    }
    x
}

/// The local prediction loss of a representation `v (B, N or 1, n, n)` of `O_t` (module
/// docs, steps 2 and 3), sampled by C when `by_c` (every layer but W's `pa`), recorded in the
/// current scope.
fn local_prediction(
    cortex: &Cortex,
    tape: &mut Tape<f32>,
    prediction: &Prediction,
    sampling: &Sampling,
    (v, by_c): (Var, bool),
    o2: Var,
) -> Var {
    let (warped, _) = PBucket::resample(tape, sampling, v);
    let sampled = match (&cortex.c, prediction.decoded.c) {
        (Some(cb), Some(c)) if by_c => cb.sample(tape, c, warped),
        _ => warped,
    };
    let predicted = cortex.w.encode(tape, prediction.decoded.w, sampled);
    let border_px = cortex.config.loss.border_px;
    tape.masked_sq_error(predicted, o2, prediction.mask, border_px)
}

/// Declares one local prediction loss per layer (W, C, each of D's blocks, P) for the pair
/// `O_t`, `o2 = O_{t+1}` warped by `sampling` (P's, of the true motion, recorded in P's
/// scope), on the tape that recorded `prediction`.
pub(super) fn record_prediction_losses(
    cortex: &Cortex,
    tape: &mut Tape<f32>,
    prediction: &Prediction,
    sampling: &Sampling,
    o2: Var,
) {
    let n = cortex.n();
    let n_out = cortex.config.percept_dim();
    let d = &prediction.decoded;
    // (scope, representation, needs a read-out, sampled by C)
    let mut layers: Vec<(&'static str, Var, bool, bool)> = Vec::new();
    if cortex.w.response.is_some() {
        layers.push((
            BUCKET_NAMES[Bucket::W as usize],
            d.activations,
            false,
            false,
        ));
    }
    if cortex.c.is_some() {
        layers.push((BUCKET_NAMES[Bucket::C as usize], d.injected, false, true));
        if let crate::buckets::d::DBucket::UNet(net) = &cortex.d {
            let scopes = net.block_scopes().unwrap_or(&[]);
            let last = d.blocks.len().saturating_sub(1);
            for (k, (&scope, &h)) in scopes.iter().zip(&d.blocks).enumerate() {
                layers.push((scope, h, k != last, true));
            }
        }
    }
    for (scope, h, needs_read_out, by_c) in layers {
        tape.enter_scope(scope);
        let v = if needs_read_out {
            read_out(tape, scope, h, n_out, n)
        } else {
            h
        };
        let loss = local_prediction(cortex, tape, prediction, sampling, (v, by_c), o2);
        tape.declare_local_loss(scope, loss);
    }
    if let Sampling::Grid(_) = sampling {
        let p = BUCKET_NAMES[Bucket::P as usize];
        tape.enter_scope(p);
        let by_c = cortex.c.is_some();
        let loss = local_prediction(cortex, tape, prediction, sampling, (d.percept, by_c), o2);
        tape.declare_local_loss(p, loss);
    }
}
