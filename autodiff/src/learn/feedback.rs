//! Feedback alignment (Lillicrap et al. 2016, *Nat. Commun.* 7:13276) and its relatives: the
//! backward pass sends errors to a layer's input through a backward weight `B` instead of the
//! forward weight `W`. How `B` is made — fixed random, sign-concordant (uSF, brSF, frSF),
//! norm-matched, sign-flipped, or learned (Kolen–Pollack) — is the rule's [`FeedbackScheme`]
//! ([`scheme`] documents each with its source).
//!
//! Mechanics, for every op that declares weight inputs ([`Op::weight_inputs`]: matmul's right
//! operand, conv2d's and the transposed conv's kernel, the RealNVP coupling's MLP weights,
//! the complex multiply's and guarded divide's second operand) whose input node is a
//! trainable parameter, recorded in a scope the rule covers ([`ScopeFilter`]):
//! - the forward pass is unchanged (the rule only acts in backward);
//! - the weight's own gradient uses the real inputs (`dW = xᵀ·dy` for `x @ W`);
//! - every other input's gradient is the op's own backward with `B` substituted for `W`
//!   (`dx = dy·Bᵀ` instead of `dy·Wᵀ`), through [`NodeView::backward_with_inputs`], so any op
//!   with a weight input is covered without op-specific code.
//!
//! Everything else — ops with no weight input, weights that reach an op through another op (a
//! reshape, a normalisation), nodes outside the covered scopes — gets ordinary backprop. What
//! that means for a model is the model's to say: in the cortex, `W`'s frequency response is a
//! weight of the complex multiply of its encode, `C` is normalised before use (so it never is
//! a weight input), and the couplings of `P` and the convolutions of `D` are.
//!
//! Draws: the magnitude behind each `B` comes from a generator seeded by `(seed, ParamId)`, so
//! it does not depend on the order layers are met, scaled to the weight where it is first used
//! ([`FeedbackAlignment::new`]) or to the parameters the training started from
//! ([`FeedbackAlignment::scaled_to`]). The rule's state ([`LearningRule::state`]) holds every
//! magnitude drawn or learned and the step count, keyed by parameter name, so a resumed run
//! continues with exactly the feedback of the run that never stopped.
//!
//! [`Op::weight_inputs`]: crate::Op::weight_inputs

pub mod kolen_pollack;
pub mod scheme;

use super::{LearningRule, Objective, ParamGrads, RuleState, RuleStateError};
use crate::scopes::ScopeFilter;
use crate::tape::{BackwardHooks, NodeKind, NodeView};
use crate::{Float, GradSlots, ParamId, ParamStore, Tape, Tensor};
pub use kolen_pollack::{KolenPollackOptimizer, Moments};
pub use scheme::{sign, FeedbackScheme};
use std::collections::BTreeMap;

/// Feedback alignment: a backward weight `B` per weight parameter (module docs).
pub struct FeedbackAlignment<T: Float = f32> {
    seed: u64,
    scheme: FeedbackScheme,
    norm_matched: bool,
    flip_sign: bool,
    coverage: ScopeFilter,
    /// `σ` of each parameter's draws, fixed in advance ([`FeedbackAlignment::scaled_to`]).
    scales: BTreeMap<ParamId, f64>,
    /// The magnitude `M` of each parameter's `B` ([`scheme`]), drawn at first use.
    magnitudes: BTreeMap<ParamId, Tensor<T>>,
    /// `B` of each parameter as used in the last backward.
    current: BTreeMap<ParamId, Tensor<T>>,
    /// Adam's moments of each learned `B` (Kolen–Pollack with Adam).
    moments: BTreeMap<ParamId, Moments<T>>,
    /// Steps done (brSF redraws per step).
    steps: u64,
}

impl<T: Float> FeedbackAlignment<T> {
    /// Fixed random Gaussian feedback drawn from `seed`, each `B` scaled to its weight at the
    /// weight's first use, in every scope.
    pub fn new(seed: u64) -> Self {
        FeedbackAlignment {
            seed,
            scheme: FeedbackScheme::Random,
            norm_matched: false,
            flip_sign: false,
            coverage: ScopeFilter::All,
            scales: BTreeMap::new(),
            magnitudes: BTreeMap::new(),
            current: BTreeMap::new(),
            moments: BTreeMap::new(),
            steps: 0,
        }
    }

    /// Like [`FeedbackAlignment::new`], but each draw is scaled to that parameter's value in
    /// `start` (the parameters the training started from), whatever the weight is at its
    /// first use.
    pub fn scaled_to(seed: u64, start: &ParamStore<T>) -> Self {
        let mut rule = Self::new(seed);
        rule.scales = start
            .ids()
            .map(|id| (id, scheme::scale(start.get(id))))
            .collect();
        rule
    }

    /// The same rule with feedback made by `scheme`.
    pub fn with_scheme(mut self, scheme: FeedbackScheme) -> Self {
        self.scheme = scheme;
        self
    }

    /// The same rule with `B` rescaled at every step to `‖W‖_F` (`true`).
    pub fn norm_matched(mut self, on: bool) -> Self {
        self.norm_matched = on;
        self
    }

    /// The same rule sending `−B` (`true`): a control whose feedback points the wrong way.
    pub fn sign_flipped(mut self, on: bool) -> Self {
        self.flip_sign = on;
        self
    }

    /// The same rule acting only in the scopes `coverage` names (backprop elsewhere).
    pub fn covering(mut self, coverage: ScopeFilter) -> Self {
        self.coverage = coverage;
        self
    }

    /// The scheme.
    pub fn scheme(&self) -> FeedbackScheme {
        self.scheme
    }

    /// `B` of parameter `id` as used in the last backward.
    pub fn feedback(&self, id: ParamId) -> Option<&Tensor<T>> {
        self.current.get(&id)
    }

    /// Sets the magnitude `M` behind `id`'s feedback (for the random and Kolen–Pollack
    /// schemes, `B` itself: `W` recovers backprop in a test). Its shape must fit the scheme.
    pub fn set_feedback(&mut self, id: ParamId, m: Tensor<T>) {
        self.magnitudes.insert(id, m);
    }

    /// `B` of weight `id` whose current value is `w`, made once per step.
    fn feedback_for(&mut self, id: ParamId, w: &Tensor<T>) {
        if self.current.contains_key(&id) {
            return;
        }
        let (seed, scheme) = (self.seed, self.scheme);
        if !self.magnitudes.contains_key(&id) {
            let sigma = self
                .scales
                .get(&id)
                .copied()
                .unwrap_or_else(|| scheme::scale(w));
            let m = scheme.draw_magnitude(w, sigma, seed, id);
            self.magnitudes.insert(id, m);
        }
        let mut b = scheme.feedback(&self.magnitudes[&id], w, seed, id, self.steps);
        assert_eq!(
            b.shape(),
            w.shape(),
            "FeedbackAlignment: the feedback of parameter {id:?} does not match its weight"
        );
        if self.norm_matched {
            scheme::match_norm(&mut b, w);
        }
        if self.flip_sign {
            b.data_mut().iter_mut().for_each(|v| *v = -*v);
        }
        self.current.insert(id, b);
    }

    /// Kolen–Pollack's updates after the sweep: `B` of every weight used this step learns from
    /// `W`'s gradient, and `W`'s gradient gains its weight decay ([`scheme`]).
    fn learn_feedback(&mut self, params: &ParamStore<T>, grads: &mut ParamGrads<T>) {
        let FeedbackScheme::KolenPollack {
            learning_rate,
            weight_decay,
            optimizer,
        } = self.scheme
        else {
            return;
        };
        for &id in self.current.keys() {
            let (Some(g), Some(b)) = (grads.get_mut(id), self.magnitudes.get_mut(&id)) else {
                continue;
            };
            let moments = self.moments.entry(id).or_insert_with(|| Moments::zeros(b));
            kolen_pollack::step(optimizer, b, g, moments, learning_rate, weight_decay);
            let decay = T::of(weight_decay);
            for (g, &w) in g.data_mut().iter_mut().zip(params.get(id).data()) {
                *g += decay * w;
            }
        }
    }
}

struct Hooks<'a, T: Float> {
    rule: &'a mut FeedbackAlignment<T>,
}

impl<T: Float> BackwardHooks<T> for Hooks<'_, T> {
    fn override_vjp(
        &mut self,
        node: &NodeView<'_, T>,
        dy: &Tensor<T>,
        dx: &mut GradSlots<'_, T>,
    ) -> bool {
        let is_fa_weight = |i: usize| matches!(node.input_kinds.get(i), Some(NodeKind::Param(_)));
        let weights = node.weight_inputs();
        if !weights.iter().any(|&i| is_fa_weight(i)) || !self.rule.coverage.covers(node.scope()) {
            return false;
        }
        for &i in weights.iter().filter(|&&i| is_fa_weight(i)) {
            let NodeKind::Param(id) = node.input_kinds[i] else {
                unreachable!()
            };
            self.rule.feedback_for(id, node.input_values[i]);
        }
        let wanted: u64 = (0..dx.len().min(64))
            .filter(|&i| dx.wants(i))
            .map(|i| 1u64 << i)
            .sum();
        let fa = |i: usize| weights.contains(&i) && is_fa_weight(i);

        // 1. The weights' own gradients, with the real inputs.
        for i in 0..dx.len() {
            dx.set_wanted(i, wanted & (1 << i) != 0 && fa(i));
        }
        node.backward_with_inputs(node.input_values, dy, dx);

        // 2. Every other input's gradient, with B in place of each weight.
        let substituted: Vec<&Tensor<T>> = (0..node.input_values.len())
            .map(|i| match node.input_kinds[i] {
                NodeKind::Param(id) if fa(i) => &self.rule.current[&id],
                _ => node.input_values[i],
            })
            .collect();
        for i in 0..dx.len() {
            dx.set_wanted(i, wanted & (1 << i) != 0 && !fa(i));
        }
        node.backward_with_inputs(&substituted, dy, dx);
        for i in 0..dx.len() {
            dx.set_wanted(i, wanted & (1 << i) != 0);
        }
        true
    }
}

impl<T: Float> LearningRule<T> for FeedbackAlignment<T> {
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        self.current.clear();
        tape.backward_with(objective.loss, &mut Hooks { rule: self });
        grads.fill_from_tape(tape);
        self.learn_feedback(params, grads);
        self.steps += 1;
    }

    fn state(&self, params: &ParamStore<T>) -> RuleState<T> {
        let mut s = RuleState::new();
        for (&id, m) in &self.magnitudes {
            s.tensors
                .insert(format!("feedback.{}", params.name(id)), m.clone());
        }
        for (&id, m) in &self.moments {
            let name = params.name(id);
            s.tensors.insert(format!("adam_m.{name}"), m.m.clone());
            s.tensors.insert(format!("adam_v.{name}"), m.v.clone());
            s.metadata
                .insert(format!("adam_steps.{name}"), m.steps.to_string());
        }
        s.metadata
            .insert("scheme".into(), self.scheme.name().into());
        s.metadata.insert("steps".into(), self.steps.to_string());
        s
    }

    fn load_state(
        &mut self,
        state: &RuleState<T>,
        params: &ParamStore<T>,
    ) -> Result<(), RuleStateError> {
        let scheme = state.metadata.get("scheme").map(String::as_str);
        if scheme != Some(self.scheme.name()) {
            return Err(RuleStateError::Invalid {
                key: "scheme".into(),
                reason: format!(
                    "the state is of scheme {scheme:?}, this rule's is {:?}",
                    self.scheme.name()
                ),
            });
        }
        let (mut magnitudes, mut moments) = (BTreeMap::new(), BTreeMap::new());
        for (key, t) in &state.tensors {
            let (kind, name) = key.split_once('.').unwrap_or((key, ""));
            let id = params
                .find(name)
                .filter(|_| matches!(kind, "feedback" | "adam_m" | "adam_v"))
                .ok_or_else(|| RuleStateError::Unexpected {
                    key: key.clone(),
                    reason: "not the feedback or Adam moment of a parameter".into(),
                })?;
            if kind == "feedback" {
                magnitudes.insert(id, t.clone());
                continue;
            }
            let entry = moments.entry(id).or_insert_with(|| Moments::zeros(t));
            entry.steps = state.counter(&format!("adam_steps.{name}"))?;
            if kind == "adam_m" {
                entry.m = t.clone();
            } else {
                entry.v = t.clone();
            }
        }
        self.steps = state.counter("steps")?;
        self.magnitudes = magnitudes;
        self.moments = moments;
        self.current.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests;
