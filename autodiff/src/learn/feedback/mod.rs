//! Feedback alignment (Lillicrap et al. 2016, *Nat. Commun.* 7:13276): the backward pass sends
//! errors to a layer's input through a fixed random matrix `B` instead of the forward weight `W`.
//!
//! Mechanics, for every op that declares weight inputs ([`Op::weight_inputs`]:
//! matmul's right operand, conv2d's kernel) whose input node is a trainable parameter:
//! - the forward pass is unchanged (the rule only acts in backward);
//! - the weight's own gradient uses the real inputs (`dW = xᵀ·dy` for `x @ W`);
//! - every other input's gradient is the op's own backward with `B` substituted for `W`
//!   (`dx = dy·Bᵀ` instead of `dy·Wᵀ`), through
//!   [`NodeView::backward_with_inputs`], so any op with a weight input is covered without
//!   op-specific code.
//!
//! `B` is drawn once per parameter, on first use, from `N(0, σ²)` with a generator seeded by
//! `(seed, ParamId)`, so it does not depend on the order layers are met. `σ` matches the weight's
//! scale: the RMS of `W`, or, for an all-zero `W`, `1/√fan_in` with `fan_in = dims[0]` for a
//! rank-2 `(in, out)` matmul weight and `numel / dims[0]` for a `(out, in, kh, kw)` kernel.
//! [`FeedbackAlignment::new`] takes `W` at its first use; [`FeedbackAlignment::scaled_to`]
//! takes it from a given set of parameters (those a run started from), so that a run resumed
//! from a checkpoint draws the same `B` as the run that never stopped: `B` is then a function
//! of the seed and the starting parameters alone. A weight that reaches an op through another
//! op (a reshape, a scale) is not a parameter node there and gets ordinary backprop.
//!
//! [`Op::weight_inputs`]: crate::Op::weight_inputs

use super::{LearningRule, Objective, ParamGrads};
use crate::tape::{BackwardHooks, NodeKind, NodeView};
use crate::{Float, GradSlots, ParamId, ParamStore, Tape, Tensor};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::BTreeMap;

/// Feedback alignment with fixed random backward weights, one `B` per weight parameter.
pub struct FeedbackAlignment<T: Float = f32> {
    seed: u64,
    feedback: BTreeMap<ParamId, Tensor<T>>,
    /// `σ` of each parameter's `B`, fixed in advance ([`FeedbackAlignment::scaled_to`]).
    scales: BTreeMap<ParamId, f64>,
}

impl<T: Float> FeedbackAlignment<T> {
    /// A rule whose feedback matrices are drawn from `seed`, each scaled to its weight at the
    /// weight's first use.
    pub fn new(seed: u64) -> Self {
        FeedbackAlignment {
            seed,
            feedback: BTreeMap::new(),
            scales: BTreeMap::new(),
        }
    }

    /// A rule whose feedback matrices are drawn from `seed`, each scaled to that parameter's
    /// value in `start` (the parameters the training started from), whatever the weight is at
    /// its first use.
    pub fn scaled_to(seed: u64, start: &ParamStore<T>) -> Self {
        let mut rule = Self::new(seed);
        rule.scales = start.ids().map(|id| (id, scale(start.get(id)))).collect();
        rule
    }

    /// The feedback matrix of parameter `id`, once it has been drawn.
    pub fn feedback(&self, id: ParamId) -> Option<&Tensor<T>> {
        self.feedback.get(&id)
    }

    /// Sets the feedback matrix of `id` (e.g. restored from a checkpoint, or `W` itself to
    /// recover backprop in a test). Its shape must match the parameter's.
    pub fn set_feedback(&mut self, id: ParamId, b: Tensor<T>) {
        self.feedback.insert(id, b);
    }

    fn draw(&self, id: ParamId, w: &Tensor<T>) -> Tensor<T> {
        let sigma = self.scales.get(&id).copied().unwrap_or_else(|| scale(w));
        // SplitMix-style mixing so neighbouring ids get unrelated streams.
        let mut s = self.seed ^ (u64::from(id.0) + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        s = (s ^ (s >> 31)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        let mut rng = StdRng::seed_from_u64(s);
        Tensor::from_fn(w.shape(), |_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            T::of(sigma * z)
        })
    }
}

/// `σ` of the feedback matrix of weight `w` (module docs).
fn scale<T: Float>(w: &Tensor<T>) -> f64 {
    let n = w.numel().max(1);
    let rms = (w.sum_sq() / n as f64).sqrt();
    if rms > 0.0 {
        return rms;
    }
    let d = w.dims();
    let fan_in = match d.len() {
        0 => 1,
        2 => d[0],
        _ => n / d[0].max(1),
    };
    1.0 / (fan_in.max(1) as f64).sqrt()
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
        if !weights.iter().any(|&i| is_fa_weight(i)) {
            return false;
        }
        for &i in weights.iter().filter(|&&i| is_fa_weight(i)) {
            let NodeKind::Param(id) = node.input_kinds[i] else {
                unreachable!()
            };
            if !self.rule.feedback.contains_key(&id) {
                let b = self.rule.draw(id, node.input_values[i]);
                self.rule.feedback.insert(id, b);
            }
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

        // 2. Every other input's gradient, with B in place of each FA weight.
        let substituted: Vec<&Tensor<T>> = (0..node.input_values.len())
            .map(|i| match node.input_kinds[i] {
                NodeKind::Param(id) if fa(i) => &self.rule.feedback[&id],
                _ => node.input_values[i],
            })
            .collect();
        for (i, b) in substituted.iter().enumerate() {
            assert_eq!(
                b.shape(),
                node.input_values[i].shape(),
                "FeedbackAlignment: feedback for input {i} of {} has the wrong shape",
                node.name
            );
        }
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
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        tape.backward_with(objective.loss, &mut Hooks { rule: self });
        grads.fill_from_tape(tape);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::Backprop;

    /// `L = Σ (relu(x W1) W2 − t)²` with W1 (3, 4), W2 (4, 2).
    fn run(rule: &mut dyn LearningRule<f64>, params: &ParamStore<f64>) -> ParamGrads<f64> {
        let mut tape = Tape::new();
        let x = tape.constant(Tensor::from_fn([5, 3], |i| (i as f64 * 0.37).sin()));
        let t = tape.constant(Tensor::from_fn([5, 2], |i| (i as f64 * 0.91).cos()));
        let (w1, w2) = (
            params.var(&mut tape, ParamId(0)),
            params.var(&mut tape, ParamId(1)),
        );
        let h = tape.matmul(x, w1);
        let h = tape.relu(h);
        let y = tape.matmul(h, w2);
        let e = tape.sub(y, t);
        let e = tape.square(e);
        let loss = tape.sum(e);
        rule.assign_credit(&mut tape, loss.into(), params)
    }

    fn params() -> ParamStore<f64> {
        let mut p = ParamStore::new();
        p.add(
            "w1",
            Tensor::from_fn([3, 4], |i| ((i * 7 % 11) as f64 - 5.0) / 6.0),
        );
        p.add(
            "w2",
            Tensor::from_fn([4, 2], |i| ((i * 5 % 9) as f64 - 4.0) / 5.0),
        );
        p
    }

    #[test]
    fn feedback_equal_to_the_weight_recovers_backprop() {
        let p = params();
        let bp = run(&mut Backprop, &p);
        let mut fa = FeedbackAlignment::new(1);
        fa.set_feedback(ParamId(1), p.get(ParamId(1)).clone());
        fa.set_feedback(ParamId(0), p.get(ParamId(0)).clone());
        let g = run(&mut fa, &p);
        for id in p.ids() {
            assert!(g.get(id).unwrap().max_abs_diff(bp.get(id).unwrap()) < 1e-12);
        }
    }

    #[test]
    fn random_feedback_changes_only_the_hidden_layer() {
        let p = params();
        let bp = run(&mut Backprop, &p);
        let mut fa = FeedbackAlignment::new(42);
        let g = run(&mut fa, &p);
        // The output layer sees the true error; the hidden layer sees it through B2.
        assert!(
            g.get(ParamId(1))
                .unwrap()
                .max_abs_diff(bp.get(ParamId(1)).unwrap())
                < 1e-12
        );
        assert!(
            g.get(ParamId(0))
                .unwrap()
                .max_abs_diff(bp.get(ParamId(0)).unwrap())
                > 1e-3
        );
        // B is fixed: a second pass gives the same result, and B matches W's scale.
        let b = fa.feedback(ParamId(1)).unwrap().clone();
        let g2 = run(&mut fa, &p);
        assert_eq!(fa.feedback(ParamId(1)).unwrap(), &b);
        assert_eq!(g2.get(ParamId(0)).unwrap(), g.get(ParamId(0)).unwrap());
        let rms = |t: &Tensor<f64>| (t.sum_sq() / t.numel() as f64).sqrt();
        let ratio = rms(&b) / rms(p.get(ParamId(1)));
        assert!((0.3..3.0).contains(&ratio), "B scale ratio {ratio}");
    }

    #[test]
    fn feedback_scaled_to_the_start_does_not_depend_on_the_weights_at_first_use() {
        let start = params();
        let mut trained = params();
        for id in trained.ids().collect::<Vec<_>>() {
            let w = trained.get(id).clone();
            *trained.get_mut(id) = Tensor::from_fn(w.shape(), |i| 3.0 * w.data()[i] + 0.1);
        }
        let mut from_start = FeedbackAlignment::scaled_to(7, &start);
        let mut resumed = FeedbackAlignment::scaled_to(7, &start);
        let mut first_use = FeedbackAlignment::new(7);
        run(&mut from_start, &start);
        run(&mut resumed, &trained);
        run(&mut first_use, &trained);
        let b = |fa: &FeedbackAlignment<f64>| fa.feedback(ParamId(1)).unwrap().clone();
        assert_eq!(b(&from_start), b(&resumed));
        assert_ne!(b(&from_start), b(&first_use));
    }
}
