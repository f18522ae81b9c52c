//! The cortex's optimiser: Adam (the authors' code) or SGD with momentum, chosen by
//! `cortex.train.optimizer` ([`crate::config::OptimizerName`]).
//!
//! Both are `autodiff::optim` rules; [`CortexUpdate`] picks one at run time so that the trainer
//! and its checkpoints have one type. The checkpoint's state keys are the chosen rule's
//! (`"{param}::adam.m"`, `"{param}::sgd.velocity"`), so a checkpoint of one optimiser does not
//! load into a run of the other: the load names the missing key.
//!
//! Sign: gradients are `∂L/∂θ`; both rules subtract them.

use crate::config::{OptimizerName, TrainConfig};
use crate::credit::learned_bucket_of_params;
use crate::model::LEARNED_BUCKETS;
use crate::Cortex;
use autodiff::optim::{Adam, Optimizer, Sgd, UpdateRule};
use autodiff::Tensor;

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
        assert_eq!(UpdateRule::<f32>::slots(&adam), &["m", "v"]);
        t.optimizer = OptimizerName::Sgd;
        t.sgd_momentum = 0.9;
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
