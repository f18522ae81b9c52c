//! P's inverse without a hole: a coupling whose log-scale is pushed to overflow `exp(−s)` in
//! P⁻¹(P(uv) + d̂). With the bounded log-scale (every preset) training goes on with finite
//! gradients; with the authors' unbounded form it either goes on or stops with an error
//! that names the op and bucket that made the first non-finite value — never with NaN
//! parameters.

use cortex::config::CortexConfig;
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{CortexError, Trainer};

/// A tiny trainer whose last coupling (the first one P⁻¹ applies) has its log-scale bias at
/// `s_bias`.
fn pushed_trainer(bound: Option<f64>, s_bias: f32) -> (Trainer, SyntheticSource) {
    let mut cfg = CortexConfig::tiny();
    cfg.p.log_scale_bound = bound;
    let last = cfg.p.couplings - 1;
    let mut t = Trainer::new(cfg.clone()).unwrap();
    let id = t
        .cortex
        .params
        .find(&format!("p.block{last}.fc3.bias"))
        .expect("the flow's last coupling");
    t.cortex.params.get_mut(id).data_mut()[1] = s_bias;
    let src = SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 5));
    (t, src)
}

fn params_finite(t: &Trainer) -> bool {
    let p = &t.cortex.params;
    p.ids()
        .all(|id| p.get(id).data().iter().all(|v| v.is_finite()))
}

#[test]
fn a_bounded_log_scale_trains_through_a_pushed_coupling() {
    for s_bias in [-95.0, 95.0] {
        let (mut t, mut src) = pushed_trainer(Some(2.0), s_bias);
        let mut losses = Vec::new();
        t.run(&mut src, 3, None, |st, _| losses.push(st.loss))
            .unwrap();
        assert!(losses.iter().all(|l| l.is_finite()), "{losses:?}");
        assert!(params_finite(&t));
    }
}

#[test]
fn an_unbounded_log_scale_never_leaves_nan_parameters() {
    let (mut t, mut src) = pushed_trainer(None, -95.0);
    match t.run(&mut src, 3, None, |_, _| {}) {
        Ok(()) => println!("trained on"),
        Err(e @ (CortexError::NonFiniteGradient { .. } | CortexError::NonFiniteLoss { .. })) => {
            let msg = e.to_string();
            println!("{msg}");
            assert!(msg.contains("first produced by `"), "{msg}");
            assert!(msg.contains("bucket P"), "{msg}");
        }
        Err(other) => panic!("unexpected error {other}"),
    }
    assert!(params_finite(&t));
}
