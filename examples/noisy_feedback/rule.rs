//! A learning rule written outside the library, in this one file: **noisy feedback**. Errors
//! travel back through `B = W + ρ·σ_W·N` instead of `W`, with `N` a fixed standard Gaussian
//! draw per weight and `σ_W` the RMS of `W` where it is first used. `ρ = 0` is backprop;
//! a large `ρ` is feedback alignment with a random `B`. Between them it asks the question of
//! Liao, Leibo & Poggio (2016, "How important is weight symmetry in backpropagation?") one
//! knob at a time: how much of the forward weights must the backward pass know?
//!
//! What it shows, each in a few lines:
//! - **settings** read from the `[rule]` table of a run's config ([`Settings`]; a typo is an
//!   error naming the field);
//! - **a backward hook** ([`BackwardHooks::override_vjp`]) that swaps the weight of every op
//!   declaring one (`Op::weight_inputs`: convolutions, matmuls, the couplings, W's filter) for
//!   `B` in the error sent to the op's other inputs, while the weight's own gradient uses the
//!   real inputs;
//! - **state** for checkpoints ([`LearningRule::state`], [`LearningRule::load_state`]): the
//!   noise draws, by parameter name, so `resume` continues bit-identically;
//! - **registration** ([`entry`]): one call, `cortex::rule::register(rule::entry())`, in the
//!   binary's `main` makes `learning_rule = "noisy-feedback"` valid in `--config` files and in
//!   sweep grids.

use autodiff::learn::{LearningRule, Objective, ParamGrads, RuleState, RuleStateError};
use autodiff::{BackwardHooks, GradSlots, NodeKind, NodeView, ParamId, ParamStore, Tape, Tensor};
use cortex::{RuleContext, RuleEntry};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::BTreeMap;

/// The rule's settings, from the `[rule]` table.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// `ρ`, the noise relative to the weight's RMS (default 0.5).
    #[serde(default = "half")]
    pub noise: f64,
    /// Seed of the noise (default: the run's seed).
    #[serde(default)]
    pub feedback_seed: Option<u64>,
}

fn half() -> f64 {
    0.5
}

/// Noisy feedback: `B = W + ρ·σ_W·N` (module docs).
pub struct NoisyFeedback {
    noise: f64,
    seed: u64,
    /// `σ_W·N` per weight, drawn at first use.
    draws: BTreeMap<ParamId, Tensor<f32>>,
}

impl NoisyFeedback {
    /// The rule with relative noise `noise`, drawn from `seed`.
    pub fn new(noise: f64, seed: u64) -> Self {
        NoisyFeedback {
            noise,
            seed,
            draws: BTreeMap::new(),
        }
    }

    /// `B` of weight `id` whose value is `w`.
    fn feedback(&mut self, id: ParamId, w: &Tensor<f32>) -> Tensor<f32> {
        let seed = self.seed ^ u64::from(id.0).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let n = self.draws.entry(id).or_insert_with(|| {
            let sigma = (w.sum_sq() / w.numel().max(1) as f64).sqrt();
            let mut rng = StdRng::seed_from_u64(seed);
            Tensor::from_fn(w.shape(), |_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                (sigma * z) as f32
            })
        });
        let rho = self.noise as f32;
        Tensor::from_fn(w.shape(), |i| w.data()[i] + rho * n.data()[i])
    }
}

impl BackwardHooks<f32> for NoisyFeedback {
    fn override_vjp(
        &mut self,
        node: &NodeView<'_, f32>,
        dy: &Tensor<f32>,
        dx: &mut GradSlots<'_, f32>,
    ) -> bool {
        let weight = |i: usize| match node.input_kinds.get(i) {
            Some(&NodeKind::Param(id)) if node.weight_inputs().contains(&i) => Some(id),
            _ => None,
        };
        if !(0..dx.len()).any(|i| weight(i).is_some()) {
            return false;
        }
        let wanted: Vec<bool> = (0..dx.len()).map(|i| dx.wants(i)).collect();
        // 1. each weight's own gradient, from the real inputs
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w && weight(i).is_some());
        }
        node.backward_with_inputs(node.input_values, dy, dx);
        // 2. the error sent to every other input, through B in place of each weight
        let substituted: Vec<Tensor<f32>> = (0..wanted.len())
            .map(|i| match weight(i) {
                Some(id) => self.feedback(id, node.input_values[i]),
                None => node.input_values[i].clone(),
            })
            .collect();
        let refs: Vec<&Tensor<f32>> = substituted.iter().collect();
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w && weight(i).is_none());
        }
        node.backward_with_inputs(&refs, dy, dx);
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w);
        }
        true
    }
}

impl LearningRule<f32> for NoisyFeedback {
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<f32>,
        objective: Objective,
        _params: &ParamStore<f32>,
        grads: &mut ParamGrads<f32>,
    ) {
        tape.backward_with(objective.loss, self);
        grads.fill_from_tape(tape);
    }

    fn state(&self, params: &ParamStore<f32>) -> RuleState<f32> {
        let mut s = RuleState::new();
        for (&id, n) in &self.draws {
            s.tensors
                .insert(format!("noise.{}", params.name(id)), n.clone());
        }
        s
    }

    fn load_state(
        &mut self,
        state: &RuleState<f32>,
        params: &ParamStore<f32>,
    ) -> Result<(), RuleStateError> {
        let mut draws = BTreeMap::new();
        for (key, n) in &state.tensors {
            let id = key
                .strip_prefix("noise.")
                .and_then(|name| params.find(name))
                .ok_or_else(|| RuleStateError::Unexpected {
                    key: key.clone(),
                    reason: "not the noise of a parameter".into(),
                })?;
            draws.insert(id, n.clone());
        }
        self.draws = draws;
        Ok(())
    }
}

/// The registry entry: `learning_rule = "noisy-feedback"`, settings [`Settings`].
pub fn entry() -> RuleEntry {
    RuleEntry::new(
        "noisy-feedback",
        "errors sent back through W plus fixed Gaussian noise of relative size `noise`",
        |s: Settings, ctx: &RuleContext<'_>| {
            Box::new(NoisyFeedback::new(s.noise, ctx.draw_seed(s.feedback_seed)))
        },
    )
}
