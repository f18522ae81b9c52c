//! The cortex's optimiser: Adam (the authors' code) or SGD with momentum, chosen by
//! `cortex.train.optimizer` ([`OptimizerName`]).
//!
//! Both are `autodiff::optim` rules; [`CortexUpdate`] picks one at run time so that the trainer
//! and its checkpoints have one type. The checkpoint's state keys are the chosen rule's
//! (`"{param}::adam.m"`, `"{param}::sgd.velocity"`). A resumed run takes its optimiser from the
//! checkpoint's own config, so it continues with the state it saved; a continued run
//! ([`crate::Trainer::continue_from`]: boosting, gene therapy) starts a fresh optimiser.
//!
//! Sign: gradients are `∂L/∂θ`; both rules subtract them.

use crate::config::TrainConfig;
use crate::credit::learned_bucket_of_params;
use crate::model::LEARNED_BUCKETS;
use crate::Cortex;
use autodiff::optim::{Adam, Optimizer, Sgd, UpdateRule};
use autodiff::Tensor;
use serde::{Deserialize, Serialize};

/// The optimiser of a run ([`CortexUpdate`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OptimizerName {
    /// Adam with `adam_beta1`, `adam_beta2`, `adam_eps` (authors' code).
    #[default]
    Adam,
    /// SGD with momentum `sgd_momentum`.
    Sgd,
}

impl OptimizerName {
    /// Whether this is Adam, the default (left out of a written config).
    pub fn is_adam(&self) -> bool {
        *self == OptimizerName::Adam
    }
}

/// The update rule of a cortex run.
#[derive(Clone, Copy, Debug)]
pub enum CortexUpdate {
    /// Adam with the run's β₁, β₂, ε.
    Adam(Adam),
    /// SGD, `v ← μ·v + g`, `θ ← θ − lr·v`.
    Sgd(Sgd),
}

impl CortexUpdate {
    /// The rule `train` names, with its settings.
    pub fn from_config(t: &TrainConfig) -> Self {
        match t.optimizer {
            OptimizerName::Adam => CortexUpdate::Adam(Adam {
                beta1: t.adam_beta1,
                beta2: t.adam_beta2,
                eps: t.adam_eps,
            }),
            OptimizerName::Sgd => CortexUpdate::Sgd(Sgd {
                momentum: t.sgd_momentum,
            }),
        }
    }
}

impl UpdateRule<f32> for CortexUpdate {
    fn name(&self) -> &'static str {
        match self {
            CortexUpdate::Adam(a) => UpdateRule::<f32>::name(a),
            CortexUpdate::Sgd(s) => UpdateRule::<f32>::name(s),
        }
    }
    fn slots(&self) -> &'static [&'static str] {
        match self {
            CortexUpdate::Adam(a) => UpdateRule::<f32>::slots(a),
            CortexUpdate::Sgd(s) => UpdateRule::<f32>::slots(s),
        }
    }
    fn update(&self, p: &mut [f32], g: &[f32], slots: &mut [Tensor<f32>], step: u64, lr: f64) {
        match self {
            CortexUpdate::Adam(a) => a.update(p, g, slots, step, lr),
            CortexUpdate::Sgd(s) => s.update(p, g, slots, step, lr),
        }
    }
}

/// The cortex's optimiser.
pub type CortexOptimizer = Optimizer<f32, CortexUpdate>;

/// The optimiser of `cortex`'s settings, with W's learning-rate scale and the per-bucket
/// factors. Its learning rate is given at each step, from
/// [`crate::config::TrainConfig::learning_rate_at`], the one place it is decided.
pub fn optimizer(cortex: &Cortex) -> CortexOptimizer {
    let t = &cortex.config.train;
    let mut optim = Optimizer::new(CortexUpdate::from_config(t));
    let buckets = learned_bucket_of_params(&cortex.params);
    for (id, bucket) in cortex.params.ids().zip(buckets) {
        if let Some(k) = bucket {
            optim.set_lr_scale(id, t.learning_rate_scale(LEARNED_BUCKETS[k]));
        }
    }
    optim
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_name_gives_its_rule_and_the_rules_state_slots() {
        let mut t = crate::CortexConfig::preset("tiny").unwrap().train;
        let adam = CortexUpdate::from_config(&t);
        assert_eq!(UpdateRule::<f32>::name(&adam), "adam");
        assert_eq!(UpdateRule::<f32>::slots(&adam), &["m", "v"]);
        // The default is Adam's update to the bit, step after step.
        let plain = Adam {
            beta1: t.adam_beta1,
            beta2: t.adam_beta2,
            eps: t.adam_eps,
        };
        let (mut p, mut q) = (vec![0.3f32, -1.2, 2.0], vec![0.3f32, -1.2, 2.0]);
        let zeros = || vec![Tensor::zeros([3]), Tensor::zeros([3])];
        let (mut sp, mut sq) = (zeros(), zeros());
        for step in 1..=4 {
            let g = [0.5 * step as f32, -0.1, 1e-3];
            adam.update(&mut p, &g, &mut sp, step, 1e-3);
            plain.update(&mut q, &g, &mut sq, step, 1e-3);
        }
        assert_eq!(p, q);
        t.optimizer = OptimizerName::Sgd;
        let sgd = CortexUpdate::from_config(&t);
        assert_eq!(UpdateRule::<f32>::name(&sgd), "sgd");
        assert_eq!(UpdateRule::<f32>::slots(&sgd), &["velocity"]);
        // Two steps of SGD with momentum on g = 1: v = 1 then 1.9, θ = −0.1 then −0.29.
        let (mut p, mut slots) = (vec![0.0f32], vec![Tensor::zeros([1])]);
        sgd.update(&mut p, &[1.0], &mut slots, 1, 0.1);
        sgd.update(&mut p, &[1.0], &mut slots, 2, 0.1);
        assert!((p[0] + 0.29).abs() < 1e-6, "{}", p[0]);
    }
}
