use super::*;
use crate::config::CortexConfig;
use crate::synthetic::{SyntheticConfig, SyntheticSource};
use crate::{DataSource, OnsBatch, Trainer};
use autodiff::learn::{
    Backprop, ForwardForward, LearningRule, LocalObjective, Objective, ParamGrads,
};
use autodiff::Tensor;

#[test]
fn the_wrong_motion_is_another_samples() {
    let m = [[1.0, 0.0], [0.0, 2.0], [3.0, 3.0]];
    assert_eq!(wrong_motion(&m), vec![[0.0, 2.0], [3.0, 3.0], [1.0, 0.0]]);
    assert_eq!(wrong_motion(&[[1.0, -2.0]]), vec![[-1.0, 2.0]]);
}

/// The prediction of `batch` recorded on the trainer's tape: `(prediction, O_{t+1}, motion)`.
fn record(t: &mut Trainer, batch: &OnsBatch) -> (Prediction, Var, MotionOut) {
    batch.frames(0, &mut t.frames[0]);
    batch.frames(1, &mut t.frames[1]);
    let motion = (t.cortex)
        .estimate_motion(&t.frames[0], &t.frames[1], batch.oracle_motion.as_deref())
        .unwrap();
    let (pred, o2) = t.record_frames((batch.batch, batch.n), &motion);
    (pred, o2, motion)
}

/// The credit `rule` assigns on `batch`, with the local objectives when it asks (no update).
fn credit(t: &mut Trainer, batch: &OnsBatch, rule: &mut dyn LearningRule<f32>) -> ParamGrads<f32> {
    let (pred, o2, motion) = record(t, batch);
    if rule.needs_local_losses() {
        record_local_losses(
            &t.cortex,
            &mut t.tape,
            &pred,
            o2,
            &motion,
            rule.local_objective(),
        );
    }
    let objective = Objective::with_output(pred.loss, pred.predicted);
    rule.assign_credit(&mut t.tape, objective, &t.cortex.params)
}

fn tiny() -> (Trainer, OnsBatch) {
    let cfg = CortexConfig::tiny();
    let batch = SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 3)).next_batch(2);
    (Trainer::new(cfg).unwrap(), batch)
}

#[test]
fn a_coarse_block_is_warped_through_p_at_its_own_resolution() {
    let (t, _) = tiny();
    let n = t.cortex.n();
    let mut tape = Tape::<f32>::new();
    let img = Tensor::from_fn([1, 1, n / 2, n / 2], |i| ((i * 37 % 101) as f32) / 50.0);
    let img = tape.constant(img);
    // P starts as the identity; a motion of 2 ONS pixels is 1 pixel of a 2× coarser block
    let px = 2.0 / ((n as f64 - 1.0) / 2.0);
    for (motion, shift) in [([0.0, 0.0], 0usize), ([px, 0.0], 1)] {
        let fine = t.cortex.p.sampling(&mut tape, &t.cortex.params, &[motion]);
        let coarse = coarse_sampling(&mut tape, &fine, n, 2);
        let (warped, _) = PBucket::resample(&mut tape, &coarse, img);
        let (w, src, m) = (tape.value(warped), tape.value(img), n / 2);
        for y in 1..m - 1 {
            for x in 1..m - 2 {
                let (got, want) = (w.data()[y * m + x], src.data()[y * m + x + shift]);
                assert!(
                    (got - want).abs() < 1e-4,
                    "shift {shift} at ({y}, {x}): {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn every_layer_has_its_objective_and_the_re_encoder_trains_w_and_c() {
    let (mut t, batch) = tiny();
    let g = credit(&mut t, &batch, &mut ForwardForward::default());
    let scopes: Vec<&str> = t.tape.local_losses().iter().map(|x| x.0).collect();
    assert_eq!(
        scopes,
        ["W", "C", "D.inc", "D.down1", "D.up1", "P", REENCODE_SCOPE]
    );
    // every parameter backprop moves, forward-forward moves (at the start P's last layers
    // are zero, so no gradient reaches its hidden layers under either)
    let bp = credit(&mut t, &batch, &mut Backprop);
    for id in t.cortex.params.ids() {
        let name = t.cortex.params.name(id);
        let norm = |g: &ParamGrads<f32>| g.get(id).map_or(0.0, |g| g.sum_sq());
        assert_eq!(norm(&g) > 0.0, norm(&bp) > 0.0, "{name}");
    }
    let w = t.cortex.params.find("w.response").unwrap();
    assert!(
        g.get(w).unwrap().sum_sq() > 0.0,
        "W learns under forward-forward"
    );
}

#[test]
fn no_gradient_crosses_a_block_of_the_u_net() {
    // Changing a block downstream changes every objective after it; the first block's update
    // must not change under forward-forward, and does under backprop.
    let (mut t, batch) = tiny();
    let inc = t.cortex.params.find("d.inc.conv0.weight").unwrap();
    let up = t.cortex.params.find("d.up1.conv1.weight").unwrap();
    let before_ff = credit(&mut t, &batch, &mut ForwardForward::default())
        .get(inc)
        .unwrap()
        .clone();
    let before_bp = credit(&mut t, &batch, &mut Backprop)
        .get(inc)
        .unwrap()
        .clone();
    let w = t.cortex.params.get_mut(up);
    w.data_mut().iter_mut().for_each(|v| *v *= 1.5);
    let after_ff = credit(&mut t, &batch, &mut ForwardForward::default())
        .get(inc)
        .unwrap()
        .clone();
    let after_bp = credit(&mut t, &batch, &mut Backprop)
        .get(inc)
        .unwrap()
        .clone();
    assert_eq!(before_ff, after_ff, "an objective downstream reached d.inc");
    assert!(before_bp.max_abs_diff(&after_bp) > 0.0, "the test can fail");
    assert!(
        before_ff.max_abs_diff(&before_bp) > 0.0,
        "forward-forward is not backprop"
    );
}

/// Forward-forward with each layer's own prediction ([`prediction`]).
fn predicting() -> ForwardForward {
    ForwardForward {
        objective: LocalObjective::Prediction,
    }
}

#[test]
fn under_the_prediction_objective_the_last_block_learns_from_the_true_error() {
    let (mut t, batch) = tiny();
    let g = credit(&mut t, &batch, &mut predicting());
    let scopes: Vec<&str> = t.tape.local_losses().iter().map(|x| x.0).collect();
    assert_eq!(
        scopes,
        ["W", "C", "D.inc", "D.down1", "D.up1", "P", REENCODE_SCOPE]
    );
    // D's last block reads the percept itself: its gradient is backprop's of the prediction
    // loss (no other objective reaches it).
    let (pred, _, _) = record(&mut t, &batch);
    let bp = Backprop.assign_credit(&mut t.tape, pred.main_loss.into(), &t.cortex.params);
    for name in ["d.outc.weight", "d.outc.bias", "d.up1.conv1.weight"] {
        let id = t.cortex.params.find(name).unwrap();
        let (a, b) = (g.get(id).unwrap(), bp.get(id).unwrap());
        let scale = b.data().iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(scale > 0.0, "{name}: the test can fail");
        assert!(
            a.max_abs_diff(b) <= 1e-5 * scale as f64,
            "{name}: {}",
            a.max_abs_diff(b)
        );
    }
    // A lower block learns from its own read-out: a gradient, not backprop's.
    let inc = t.cortex.params.find("d.inc.conv0.weight").unwrap();
    let (a, b) = (g.get(inc).unwrap(), bp.get(inc).unwrap());
    assert!(a.sum_sq() > 0.0);
    let cos = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x * y) as f64)
        .sum::<f64>()
        / (a.sum_sq().sqrt() * b.sum_sq().sqrt());
    assert!(
        cos < 0.99,
        "d.inc's local gradient is backprop's: cos {cos}"
    );
}

#[test]
fn a_read_out_mixes_channels_once_then_repeats_each_pixel() {
    // h (1, 2, 2, 2): channel 0 all 1, channel 1 all 2; read out to 2 channels at 4 × 4.
    let mut tape = Tape::<f32>::new();
    let h = Tensor::from_fn([1, 2, 2, 2], |i| if i < 4 { 1.0 } else { 2.0 });
    let h = tape.constant(h);
    let v = prediction::read_out(&mut tape, "D.inc", h, 2, 4);
    assert_eq!(tape.shape(v).dims(), &[1, 2, 4, 4]);
    let r = prediction::readout_weights("D.inc", 2, 2);
    for j in 0..2 {
        let want = r[j * 2] + 2.0 * r[j * 2 + 1];
        let got = &tape.value(v).data()[j * 16..(j + 1) * 16];
        assert!(
            got.iter().all(|&x| (x - want).abs() < 1e-6),
            "{j}: {got:?} vs {want}"
        );
    }
}
