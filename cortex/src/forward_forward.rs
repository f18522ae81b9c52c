//! Forward-forward for the cortex: the layer-local objectives the cortex declares when its
//! learning rule asks for them (`autodiff::learn::ForwardForward`; Hinton 2022, *The
//! Forward-Forward Algorithm: Some Preliminary Investigations*, arXiv:2212.13345).
//!
//! Hinton's algorithm, and where this one departs (and why):
//!
//! - **Layers.** Hinton: every layer has its own objective and no error travels between
//!   layers. Here a layer is a scope of the tape, and no gradient crosses a scope: W's decode
//!   (`pa = Φ_W(O)`), C's injection (`X = pa·C`), each block of D's U-Net (`D.inc`,
//!   `D.down1`, …, `D.up2`, the last with the 1×1 output conv: its output is the percept V),
//!   P (the warp's positions), and the re-encoder (below). Inside a U-Net block — two 3×3
//!   convolutions, plus the transposed conv of an up block — the gradient is exact: the block
//!   is the U-Net's unit, and a single ReLU convolution of a block has no representation of
//!   its own to score. A block's input (the block below, or the skip connection) gets nothing.
//! - **Positive and negative data.** Hinton: positive data are real (an image with its right
//!   label), negative data are made to differ only in what the network should learn (the
//!   wrong label; hybrid images; for sequences, the network's own predictions). Here the
//!   positive datum is the real triple `(O_t, O_{t+1}, d̂)`; the negative one is the same two
//!   frames with a *wrong motion*, sample `b` paired with the motion of sample `b+1` (drawn
//!   from the same distribution, so only the pairing is wrong; with a batch of one, `−d̂`). A
//!   wrong motion rather than a mismatched frame: a mismatched frame differs in content
//!   statistics a layer could detect without knowing the motion; a wrong motion can only be
//!   told from a right one by a representation that moves with the eye, which is what the
//!   cortex's buckets are for (paper §4).
//! - **Goodness.** Hinton: the sum of squared activities of the layer, high for positive data
//!   (or its negative, low for positive data). The cortex's input carries no label: the size
//!   of a layer's activity cannot tell a right motion from a wrong one. So the goodness of a
//!   layer on a pair is the negative sum of squares of *mismatch* units — its representation
//!   of `O_t` moved by the motion against its representation of `O_{t+1}`:
//!   `G = −Σ m·(warp(h_t) − h_{t+1})² / Σ m·(warp(h_t)² + h_{t+1}²)` per sample (`m` the
//!   warp's validity mask). A coarser block is warped through P's grid averaged over its
//!   cells. The normalisation (`−2 ≤ G ≤ 0`) stands where Hinton normalises each layer's
//!   activity vector before the next layer: shrinking or inflating a layer cannot raise its
//!   goodness. (The model is the same under every rule, so no normalisation is inserted
//!   between blocks.)
//! - **Objective.** Hinton: `σ(G − θ)` is the probability that a datum is positive, high on
//!   positive and low on negative data, with a threshold `θ`. Here each sample is its own
//!   positive and negative, so the two are compared directly, `mean_b softplus(β·(G⁻_b −
//!   G⁺_b))` (`autodiff::learn::pairwise_goodness_loss`, `β =` [`GOODNESS_SHARPNESS`]), and
//!   no threshold needs tuning.
//! - **The re-encoder.** Hinton reads a classification out of the layers' normalised
//!   activities with a softmax layer trained on its own error, without backpropagating into
//!   the layers (§3.3). The cortex's read-out is the re-encoder Ψ: `Ô_{t+1} =
//!   Ψ_W(⟨V̂_{t+1}, C⟩)`, W's forward filter applied to C's sampling of the warped percept. Its
//!   local objective is its own prediction error, the masked squared error of the global loss,
//!   recorded in the scope [`REENCODE_SCOPE`] with its own copies of W's response and of C, so
//!   it trains W's and C's parameters (shared with decode, which also train from their own
//!   goodness) and nothing below the warped percept.
//! - **Warps.** W's, C's and D's objectives move `h_t` through P's current sampling grid,
//!   which is P's output and gets no gradient from them. P's own objective warps the percept
//!   `V_t` (D's output, no gradient into D) and trains the flow's positions through the grid.
//!
//! What this rule leaves untrained: the motion M (its blurred objective belongs to the global
//! loss). CMF-SIM and Neural Scope read the percept `V = D(C·Φ_W(O))`, which every decode
//! objective above shapes.

use crate::buckets::p::{PBucket, Sampling};
use crate::model::{Bucket, Cortex, MotionOut, Prediction, BUCKET_NAMES};
use autodiff::learn::{pairwise_goodness_loss, LocalObjective};
use autodiff::{Tape, Var};

/// `β` of the paired objective: the normalised mismatch `−G` lies in [0, 2], so a difference
/// of 0.1 between a pair's two goodnesses is a logit of 1.
pub const GOODNESS_SHARPNESS: f64 = 10.0;

/// The scope of the re-encoder's local objective.
pub const REENCODE_SCOPE: &str = "reencode";

/// The motion of the negative data: sample `b` takes the motion of sample `b+1` (a batch of
/// one takes `−d̂`).
pub fn wrong_motion(motion: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let b = motion.len();
    if b == 1 {
        return vec![[-motion[0][0], -motion[0][1]]];
    }
    (0..b).map(|i| motion[(i + 1) % b]).collect()
}

/// `sampling` of an `n × n` layer, for a layer `f` times coarser: P's grid averaged over
/// each `f × f` cell and rescaled to the coarse grid's align-corners coordinates
/// (`u_c = u·(n − 1)/(n − f)`), or whole-pixel shifts divided by `f` and rounded.
pub fn coarse_sampling(tape: &mut Tape<f32>, sampling: &Sampling, n: usize, f: usize) -> Sampling {
    match sampling {
        _ if f == 1 => sampling.clone(),
        Sampling::Grid(grid) => {
            let b = tape.shape(*grid).dim(0);
            let (m, k) = (n / f, f);
            let cells = tape.reshape(*grid, [b, m, k, m, k, 2]);
            let mean = tape.mean_axes(cells, &[2, 4], false);
            let scaled = tape.scale(mean, (n as f64 - 1.0) / (n - f) as f64);
            Sampling::Grid(scaled)
        }
        Sampling::Shift(shifts) => Sampling::Shift(
            shifts
                .iter()
                .map(|s| s.map(|v| (v as f64 / f as f64).round() as i64))
                .collect(),
        ),
    }
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

/// The layers with a goodness objective: `(scope, h_t, h_{t+1})` (module docs).
fn layers(
    cortex: &Cortex,
    t: &crate::model::Decoded,
    t1: &crate::model::Decoded,
    warped_by_p: bool,
) -> Vec<(&'static str, Var, Var)> {
    let mut out = Vec::new();
    if cortex.w.response.is_some() {
        out.push((
            BUCKET_NAMES[Bucket::W as usize],
            t.activations,
            t1.activations,
        ));
    }
    if cortex.c.is_some() {
        out.push((BUCKET_NAMES[Bucket::C as usize], t.injected, t1.injected));
        if let crate::buckets::d::DBucket::UNet(net) = &cortex.d {
            let scopes = net.block_scopes().unwrap_or(&[]);
            for ((&scope, &h), &h1) in scopes.iter().zip(&t.blocks).zip(&t1.blocks) {
                out.push((scope, h, h1));
            }
        }
    }
    if warped_by_p {
        out.push((BUCKET_NAMES[Bucket::P as usize], t.percept, t1.percept));
    }
    out
}

/// Declares one local loss per layer for the pair `O_t`, `o2 = O_{t+1}` `(B, 1, n, n)`
/// whose (positive) motion is `motion`, and the re-encoder's, on the tape that recorded
/// `prediction` ([`Cortex::record_prediction`]; its decode of `O_t` is reused): the goodness
/// of right against wrong motion (module docs) or, for [`LocalObjective::Prediction`], each
/// layer's own prediction of `O_{t+1}` (`prediction`).
pub fn record_local_losses(
    cortex: &Cortex,
    tape: &mut Tape<f32>,
    prediction: &Prediction,
    o2: Var,
    motion: &MotionOut,
    objective: LocalObjective,
) {
    match objective {
        LocalObjective::Goodness => record_goodness_losses(cortex, tape, prediction, o2, motion),
        LocalObjective::Prediction => {
            tape.enter_scope(BUCKET_NAMES[Bucket::P as usize]);
            let pos = cortex.p.sampling(tape, &cortex.params, &motion.motion);
            prediction::record_prediction_losses(cortex, tape, prediction, &pos, o2);
        }
    }
    record_reencode_loss(cortex, tape, prediction, o2);
    tape.close_scope();
}

/// The goodness objectives (module docs).
fn record_goodness_losses(
    cortex: &Cortex,
    tape: &mut Tape<f32>,
    prediction: &Prediction,
    o2: Var,
    motion: &MotionOut,
) {
    let wrong = wrong_motion(&motion.motion);
    let t1 = cortex.record_decode(tape, o2);
    let n = cortex.n();
    tape.enter_scope(BUCKET_NAMES[Bucket::P as usize]);
    let pos = cortex.p.sampling(tape, &cortex.params, &motion.motion);
    let neg = cortex.p.sampling(tape, &cortex.params, &wrong);
    let warped_by_p = matches!(pos, Sampling::Grid(_));
    for (scope, h_t, h_t1) in layers(cortex, &prediction.decoded, &t1, warped_by_p) {
        tape.enter_scope(scope);
        let f = n / tape.shape(h_t).dim(2);
        let (p, q) = (
            coarse_sampling(tape, &pos, n, f),
            coarse_sampling(tape, &neg, n, f),
        );
        let g_pos = goodness(tape, &p, h_t, h_t1);
        let g_neg = goodness(tape, &q, h_t, h_t1);
        let loss = pairwise_goodness_loss(tape, g_pos, g_neg, GOODNESS_SHARPNESS);
        tape.declare_local_loss(scope, loss);
    }
}

/// The re-encoder's local objective: its prediction of `o2` from the warped percept, with its
/// own copies of W's response and C (module docs). Nothing to declare when neither is learned.
fn record_reencode_loss(cortex: &Cortex, tape: &mut Tape<f32>, prediction: &Prediction, o2: Var) {
    if cortex.w.response.is_none() && cortex.c.is_none() {
        return;
    }
    tape.enter_scope(REENCODE_SCOPE);
    let r = cortex.w.record(tape, &cortex.params);
    let pa = match &cortex.c {
        Some(cb) => {
            let c = cb.record(tape, &cortex.params);
            cb.sample(tape, c, prediction.warped)
        }
        None => prediction.warped,
    };
    let predicted = cortex.w.encode(tape, r, pa);
    let border = cortex.config.loss.border_px;
    let loss = tape.masked_sq_error(predicted, o2, prediction.mask, border);
    tape.declare_local_loss(REENCODE_SCOPE, loss);
}

mod prediction;
#[cfg(test)]
mod tests;
