//! Optimisation settings of the cortex: batch, learning rate and its schedule, the optimiser
//! (Adam by default, SGD with momentum), clipping, checkpoints and the alignment measurement.

use super::PerBucketTrain;
use crate::optimizer::OptimizerName;
use serde::{Deserialize, Serialize};

/// Optimisation settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    /// Samples per step (authors' code, docs/references.md#training: 8).
    pub batch_size: usize,
    /// Learning rate (authors' code, docs/references.md#training: Adam's, 1e-3).
    pub learning_rate: f64,
    /// The optimiser: `adam` (the authors' code, docs/references.md#training) or `sgd` (with
    /// [`TrainConfig::sgd_momentum`]); [`crate::optimizer`].
    #[serde(default, skip_serializing_if = "OptimizerName::is_adam")]
    pub optimizer: OptimizerName,
    /// Momentum μ of `sgd` (PyTorch's form `v ← μ·v + g`; 0.9 as in Sutskever et al. 2013,
    /// "On the importance of initialization and momentum"); unused by Adam.
    #[serde(
        default = "default_sgd_momentum",
        skip_serializing_if = "is_default_sgd_momentum"
    )]
    pub sgd_momentum: f64,
    /// Adam β₁ (authors' code, docs/references.md#training: PyTorch default 0.9).
    pub adam_beta1: f64,
    /// Adam β₂ (authors' code, docs/references.md#training: 0.999).
    pub adam_beta2: f64,
    /// Adam ε (authors' code, docs/references.md#training: 1e-8).
    pub adam_eps: f64,
    /// Seed of parameter initialisation (authors' code, docs/references.md#training: 1234).
    pub seed: u64,
    /// Gradient updates of a run (authors' code, docs/references.md#training: 100 000).
    pub steps: u64,
    /// Steps between checkpoints of a run (0: none but the last).
    pub checkpoint_every_steps: u64,
    /// Factor on the learning rate of W's response (1: the authors' single learning rate).
    /// W is identified only weakly by the loss (see `colorvision convergence` and
    /// `colorvision w-dc-gauge`); a larger factor lets Adam move it further per step, 0 holds W
    /// where it starts.
    #[serde(default = "unit_scale")]
    pub w_learning_rate_scale: f64,
    /// How the learning rate changes over the run's `steps` ([`LrSchedule`]; default constant,
    /// as the authors' code).
    #[serde(default)]
    pub lr_schedule: LrSchedule,
    /// Learning rate at the last step as a fraction of `learning_rate` (cosine schedule only).
    #[serde(default = "default_final_lr_fraction")]
    pub final_lr_fraction: f64,
    /// Largest Frobenius norm of the whole update a learning rule returns, before Adam
    /// (absent: no clipping, as the authors' code; see `config::per_bucket`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_global_norm: Option<f64>,
    /// Steps between measurements of the rule's update against backprop's gradient (one more
    /// backprop sweep on the step's tape; cosine and norms per bucket in the step's
    /// [`crate::StepStats`]); 0: never.
    #[serde(default)]
    pub alignment_every_steps: u64,
    /// Learning-rate factor and clipping per bucket (`config::per_bucket`).
    #[serde(default)]
    pub per_bucket: PerBucketTrain,
}

fn unit_scale() -> f64 {
    1.0
}

fn default_sgd_momentum() -> f64 {
    0.9
}

fn is_default_sgd_momentum(m: &f64) -> bool {
    *m == default_sgd_momentum()
}

pub(super) fn default_final_lr_fraction() -> f64 {
    0.01
}

/// The learning rate over training.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LrSchedule {
    /// `learning_rate` at every step (authors' code, docs/references.md#training).
    #[default]
    Constant,
    /// Half a cosine from `learning_rate` at step 0 to `final_lr_fraction · learning_rate` at
    /// step `steps` (Loshchilov & Hutter 2017, SGDR, without restarts); held there after.
    Cosine,
}

impl TrainConfig {
    /// The learning rate of gradient update `step` (0-based) under the schedule.
    pub fn learning_rate_at(&self, step: u64) -> f64 {
        match self.lr_schedule {
            LrSchedule::Constant => self.learning_rate,
            LrSchedule::Cosine => {
                let progress = (step as f64 / self.steps.max(1) as f64).min(1.0);
                let floor = self.final_lr_fraction;
                let factor =
                    floor + (1.0 - floor) * 0.5 * (1.0 + (std::f64::consts::PI * progress).cos());
                self.learning_rate * factor
            }
        }
    }
}
