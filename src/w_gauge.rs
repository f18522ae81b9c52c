//! Does the prediction loss single out W's zero-frequency gain? A diagnostic on a trained run
//! (`colorvision w-dc-gauge --run DIR`), not a learning result.
//!
//! W enters the cortex twice: decode divides the ONS by W, re-encode multiplies by it. Changing
//! only W's gain at zero frequency adds a uniform offset, proportional to each image's mean, to
//! the decoded cone activations; a demosaicker that maps a uniform field to a uniform percept
//! carries that offset through the warp and back, and re-encode removes it. So the DC gain is
//! close to a gauge of the model: the loss may not care where it lies. The diagnostic tests it:
//! from the run's last checkpoint, three arms continue training with W held fixed (learning-rate
//! factor 0) and its DC gain set to the learned value, the eye's true one (read from the eye,
//! which learning never does) and twice the learned one; everything else — batches, held-out
//! batches, initial parameters — is the same. Equal held-out prediction errors at the end say
//! the loss does not identify the DC gain, and a W measure should not score it.
//!
//! Output: `DIR/w-dc-gauge/<arm>/` run folders and `DIR/w-dc-gauge/gauge.json`.

use crate::run::error::RunError;
use crate::run::folder::{load_run, Folder};
use crate::run::{self, Origin, RunMode};
use retina::Retina;
use std::path::Path;

/// One arm of the diagnostic: its W DC gain and what its run measured at the end.
#[derive(Debug, Clone, serde::Serialize)]
pub struct GaugeArm {
    /// `learned`, `true` or `doubled`.
    pub name: String,
    /// W's gain at zero frequency, held for the whole arm.
    pub dc_gain: f64,
    /// Held-out prediction error of the cortex at the end (mean squared error).
    pub heldout_mse: f64,
    /// "next frame = this frame" error over the cortex's.
    pub gain_over_no_change: f64,
}

/// Runs the three arms from the last checkpoint of `run_dir`, `steps` steps each.
pub fn w_dc_gauge(run_dir: &Path, steps: u64) -> Result<Vec<GaugeArm>, RunError> {
    let lock = crate::run::lock::RunLock::acquire(run_dir)?;
    let (mut config, trainer, checkpoint) = load_run(run_dir)?;
    drop(lock);
    let learned = trainer
        .cortex
        .learned_w_dc_gain()
        .ok_or_else(|| RunError::invalid("cortex.w.mode", "W is not learned in this run"))?;
    let retina = Retina::new(config.retina.clone())?;
    let (dog, _) = retina.dog_kernel().ok_or_else(|| {
        RunError::invalid(
            "retina.lateral_inhibition",
            "this eye has no lateral inhibition",
        )
    })?;
    let true_dc: f64 = dog.iter().sum();
    config.steps = steps;
    config.cortex.train.w_learning_rate_scale = 0.0;
    let out = run_dir.join("w-dc-gauge");
    let mut arms = Vec::new();
    for (name, dc) in [
        ("learned", learned),
        ("true", true_dc),
        ("doubled", 2.0 * learned),
    ] {
        let dir = out.join(name);
        let start = dir.join("start");
        let mut t = cortex::Trainer::continue_from(&checkpoint, Some(config.cortex.clone()))?;
        t.cortex.set_w_dc_gain(dc);
        let start_checkpoint = t.save_checkpoint_with(&start, None, None)?;
        let mode = RunMode {
            cmf_sim: false,
            pictures: false,
            progress: true,
        };
        let s = run::run_in(
            &config,
            &dir.join("run"),
            mode,
            Folder::Resume,
            Origin::Continue(&start_checkpoint),
        )?;
        let [mse, _, gain] = s.heldout_prediction.unwrap_or([f64::NAN; 3]);
        println!("W DC gain {dc:.3} ({name}): held-out error {mse:.4e}, {gain:.2}× better than no change");
        arms.push(GaugeArm {
            name: name.into(),
            dc_gain: dc,
            heldout_mse: mse,
            gain_over_no_change: gain,
        });
    }
    crate::io::write_json(&out.join("gauge.json"), &arms)?;
    Ok(arms)
}
