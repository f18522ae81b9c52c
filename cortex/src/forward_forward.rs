//! Forward-forward for the cortex: the layer-local objectives the cortex declares when its
//! learning rule asks for them (`autodiff::learn::ForwardForward`; Hinton 2022,
//! arXiv:2212.13345).
//!
//! Forward-forward needs, per layer, a *goodness* that is high on positive and low on
//! negative data, computed from that layer's own activity. The cortex does not classify: it
//! predicts the next ONS frame from this one and the eye motion. Every choice below, and why:
//!
//! - **Positive data**: the real triple `(O_t, O_{t+1}, d̂)`. **Negative data**: the same two
//!   frames with a *wrong motion*, sample `b` paired with the motion of sample `b+1` of the
//!   batch (drawn from the same distribution, so only the pairing is wrong; with a batch of
//!   one, `−d̂`). A wrong motion rather than a mismatched frame: a mismatched frame differs
//!   in content statistics a layer could detect without knowing the motion; a wrong motion
//!   can only be told from a right one by a representation that moves with the eye, which is
//!   what the cortex's buckets are for (paper §4).
//! - **Layers**: the buckets, each a scope of the tape. W (its decode `pa = Φ_W(O)`), C (its
//!   injection `X = pa·C`), D (the U-Net percept `V = D(X)`) and P (the warp). A layer's
//!   representation of a frame is its output; both frames pass through the same layers.
//! - **Goodness of a layer on a pair**: how well its representation of `O_t`, moved by the
//!   motion, matches its representation of `O_{t+1}`:
//!   `G = −Σ m·(warp(h_t) − h_{t+1})² / Σ m·(warp(h_t)² + h_{t+1}²)` per sample (`m` the warp's
//!   validity mask). Normalised so that shrinking or inflating a layer's output cannot raise
//!   it (`−2 ≤ G ≤ 0`); Hinton's sum of squares would reward scale alone here, because there is
//!   no label in the input to separate positive from negative.
//! - **Objective**: paired, `mean_b softplus(β·(G⁻_b − G⁺_b))` with `β =` [`GOODNESS_SHARPNESS`]
//!   (`autodiff::learn::pairwise_goodness_loss`): each sample is its own positive and
//!   negative, so comparing them needs no threshold to tune.
//! - **No backward pass between layers**: the rule cuts every gradient that would leave a
//!   scope, so W learns from W's objective only, C from C's, D from D's. Inside D the U-Net is
//!   one layer: its blocks are trained by backprop within the bucket (forward-forward between
//!   buckets, not between the U-Net's convolutions).
//! - **Warps**: W's, C's and D's objectives move `h_t` through P's current sampling grid, which
//!   is P's output and gets no gradient from them. P's own objective warps the percept `V_t`
//!   (D's output, no gradient into D) and trains the flow's positions through the grid.
//!
//! What forward-forward cannot train here, honestly: the re-encoding Ψ. The prediction
//! `Ô_{t+1} = Ψ_W(⟨V̂_{t+1}, C⟩)` uses W's forward filter and C's sampling, which no local
//! objective contains; W and C are shared parameters, trained only by their decode-side
//! objectives, so the prediction error (what backprop minimises) is not what this rule
//! minimises, and the held-out prediction gain measures a by-product. The motion M is not
//! learned under this rule (its blurred objective belongs to the global loss). CMF-SIM and
//! Neural Scope read the percept `V = D(C·Φ_W(O))`, which every objective above shapes.

use crate::buckets::p::{PBucket, Sampling};
use crate::model::{Bucket, Cortex, MotionOut, Prediction, BUCKET_NAMES};
use autodiff::learn::pairwise_goodness_loss;
use autodiff::{Tape, Var};

/// `β` of the paired objective: the normalised mismatch `−G` lies in [0, 2], so a difference
/// of 0.1 between a pair's two goodnesses is a logit of 1.
pub const GOODNESS_SHARPNESS: f64 = 10.0;

/// The motion of the negative data: sample `b` takes the motion of sample `b+1` (a batch of
/// one takes `−d̂`).
pub fn wrong_motion(motion: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let b = motion.len();
    if b == 1 {
        return vec![[-motion[0][0], -motion[0][1]]];
    }
    (0..b).map(|i| motion[(i + 1) % b]).collect()
}

/// Goodness `G` per sample, `(B)`, of moving `h_t` by `sampling` onto `h_{t+1}` (module docs).
fn goodness(tape: &mut Tape<f32>, sampling: &Sampling, h_t: Var, h_t1: Var) -> Var {
    let (warped, mask) = PBucket::resample(tape, sampling, h_t);
    let diff = tape.sub(warped, h_t1);
    let err = tape.square(diff);
    let err = tape.mul_broadcast(err, mask);
    let err = tape.sum_axes(err, &[1, 2, 3], false);
    let (a, b) = (tape.square(warped), tape.square(h_t1));
    let energy = tape.add(a, b);
    let energy = tape.mul_broadcast(energy, mask);
    let energy = tape.sum_axes(energy, &[1, 2, 3], false);
    let energy = tape.add_scalar(energy, 1e-12);
    let ratio = tape.div(err, energy);
    tape.neg(ratio)
}

/// Declares one local loss per trained bucket for the pair `O_t`, `o2 = O_{t+1}`
/// `(B, 1, n, n)` whose (positive) motion is `motion`, on the tape that recorded `prediction`
/// ([`Cortex::record_prediction`]; its decode of `O_t` is reused).
pub fn record_local_losses(
    cortex: &Cortex,
    tape: &mut Tape<f32>,
    prediction: &Prediction,
    o2: Var,
    motion: &MotionOut,
) {
    let wrong = wrong_motion(&motion.motion);
    let (t, t1) = (prediction.decoded, cortex.record_decode(tape, o2));
    tape.enter_scope(BUCKET_NAMES[Bucket::P as usize]);
    let pos = cortex.p.sampling(tape, &cortex.params, &motion.motion);
    let neg = cortex.p.sampling(tape, &cortex.params, &wrong);
    let mut stages = vec![(Bucket::W, t.activations, t1.activations)];
    if cortex.c.is_some() {
        stages.push((Bucket::C, t.injected, t1.injected));
        if matches!(cortex.d, crate::buckets::d::DBucket::UNet(_)) {
            stages.push((Bucket::D, t.percept, t1.percept));
        }
    }
    if matches!(pos, Sampling::Grid(_)) {
        stages.push((Bucket::P, t.percept, t1.percept));
    }
    for (bucket, h_t, h_t1) in stages {
        if bucket == Bucket::W && cortex.w.response.is_none() {
            continue;
        }
        let scope = BUCKET_NAMES[bucket as usize];
        tape.enter_scope(scope);
        let g_pos = goodness(tape, &pos, h_t, h_t1);
        let g_neg = goodness(tape, &neg, h_t, h_t1);
        let loss = pairwise_goodness_loss(tape, g_pos, g_neg, GOODNESS_SHARPNESS);
        tape.declare_local_loss(scope, loss);
    }
    tape.close_scope();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wrong_motion_is_another_samples() {
        let m = [[1.0, 0.0], [0.0, 2.0], [3.0, 3.0]];
        assert_eq!(wrong_motion(&m), vec![[0.0, 2.0], [3.0, 3.0], [1.0, 0.0]]);
        assert_eq!(wrong_motion(&[[1.0, -2.0]]), vec![[-1.0, 2.0]]);
    }
}
