//! Learning works on a synthetic stream (crate-level version; the ≥ 5×
//! sandbox test with the real retina lives in the root package's tests).

use cortex::config::{CortexConfig, PMode};
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{DataSource, Trainer};

fn tiny_shift_config() -> CortexConfig {
    let mut c = CortexConfig::tiny();
    c.p.mode = PMode::IdentityIntegerShift;
    c.p.motion_ons_px_per_unit = (c.ons_size_px as f64 - 1.0) / 2.0;
    c
}

#[test]
fn prediction_error_falls_well_below_next_equals_current() {
    let cfg = tiny_shift_config();
    let n = cfg.ons_size_px;
    // shifted smooth random images through the fixed DoG, one cone type, oracle motion
    let scfg = SyntheticConfig {
        cone_probabilities: vec![1.0],
        ..SyntheticConfig::lms(n, 21)
    };
    let mut src = SyntheticSource::new(scfg.clone());
    let held_batch = SyntheticSource::new(SyntheticConfig { seed: 999, ..scfg }).next_batch(8);
    let mut t = Trainer::new(cfg).unwrap();
    let before = t.prediction_error(&held_batch).unwrap();
    let mut losses = Vec::new();
    t.run(&mut src, 150, None, |s, _| losses.push(s.loss))
        .unwrap();
    let after = t.prediction_error(&held_batch).unwrap();
    println!(
        "before {before:?}\nafter {after:?}\nloss first {:.4} last {:.4}",
        losses[0],
        losses[losses.len() - 1]
    );
    assert!(
        after.improvement() >= 5.0,
        "improvement only {:.2}",
        after.improvement()
    );
}
