//! Forward-forward (Hinton 2022, arXiv:2212.13345): every layer learns from its own objective
//! — high *goodness* on positive (real) data, low on negative data — and no error travels
//! between layers.
//!
//! The whole rule is this file, and it is the pattern for writing one:
//! 1. **What it reads.** The model declares one scalar local loss per scope
//!    ([`Tape::declare_local_loss`]), recorded inside that scope ([`Tape::enter_scope`]). The
//!    rule asks for them ([`LearningRule::needs_local_losses`]), so a model records them only
//!    under this rule. Positive and negative data go through the same recording (two batches,
//!    or one batch holding both), so one forward pass carries both.
//! 2. **How credit flows.** One reverse sweep seeded at every local loss at once. A backward
//!    hook ([`BackwardHooks::override_vjp`]) lets a gradient reach only inputs recorded in
//!    the node's own scope: a layer's input, made by the scope below, gets nothing, so there
//!    is no backward pass between layers. Inside a scope the gradient is exact (a scope may
//!    hold several ops — a layer with its normalisation, or a whole block).
//! 3. **What it returns.** The parameters' gradients of that sweep: each parameter is updated
//!    from the local losses of the scopes it was recorded in. The model's global loss is not
//!    used.
//!
//! Objectives ([`threshold_goodness_loss`], Hinton's; [`pairwise_goodness_loss`], a
//! positive/negative pair compared directly) are functions a model may use to build its local
//! losses; the rule does not depend on them.
//!
//! Sign convention: what is returned is `∂(Σ local losses)/∂θ` with cross-scope paths cut;
//! optimisers subtract it.

use super::{LearningRule, Objective, ParamGrads};
use crate::tape::{BackwardHooks, NodeView};
use crate::{Float, GradSlots, ParamStore, Tape, Tensor, Var};

/// Forward-forward: local losses per scope, no gradient across scopes (module docs); which
/// local losses the model declares is `objective`.
#[derive(Clone, Copy, Debug, Default)]
pub struct ForwardForward {
    /// The local objectives the model is asked for.
    pub objective: LocalObjective,
}

/// The family of local losses a model declares for a rule of local objectives. The rule's
/// credit is the same for every family (each scope's loss, nothing across scopes); the model
/// decides what each family means for its layers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LocalObjective {
    /// Goodness of positive against negative data per layer (Hinton 2022).
    #[default]
    Goodness,
    /// Each layer predicts the model's target through a fixed read-out of its own, trained on
    /// that local prediction error (local error signals: Mostafa, Ramesh & Cauwenberghs 2018,
    /// "Deep supervised learning using local errors"; Nøkland & Eidnes 2019, "Training neural
    /// networks with local error signals").
    Prediction,
}

/// Cuts every gradient that would leave the scope of the node it comes from.
struct ScopeWall;

impl<T: Float> BackwardHooks<T> for ScopeWall {
    fn override_vjp(
        &mut self,
        node: &NodeView<'_, T>,
        dy: &Tensor<T>,
        dx: &mut GradSlots<'_, T>,
    ) -> bool {
        let own = node.scope();
        let n = dx.len().min(64);
        let crossing = (0..n).any(|i| dx.wants(i) && node.input_scope(i) != own);
        if !crossing {
            return false;
        }
        let wanted: Vec<bool> = (0..n).map(|i| dx.wants(i)).collect();
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w && node.input_scope(i) == own);
        }
        node.backward_with_inputs(node.input_values, dy, dx);
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w);
        }
        true
    }
}

impl<T: Float> LearningRule<T> for ForwardForward {
    fn needs_local_losses(&self) -> bool {
        true
    }

    fn local_objective(&self) -> LocalObjective {
        self.objective
    }

    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        _objective: Objective,
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        let losses = tape.local_losses().to_vec();
        assert!(
            !losses.is_empty(),
            "ForwardForward: the model declared no local losses (Tape::declare_local_loss)"
        );
        let seeds: Vec<(Var, Tensor<T>)> = losses
            .iter()
            .map(|&(scope, l)| {
                assert_eq!(
                    tape.scope_of(l),
                    Some(scope),
                    "ForwardForward: the local loss of scope {scope} was recorded outside it"
                );
                (l, Tensor::full(tape.shape(l), T::one()))
            })
            .collect();
        tape.backward_from(&seeds, &mut ScopeWall);
        grads.fill_from_tape(tape);
    }
}

/// Hinton's objective: `mean_b softplus(θ − g⁺_b) + mean_b softplus(g⁻_b − θ)` for goodness
/// vectors `g⁺`, `g⁻` of shape `(B)`: the probability `σ(g − θ)` that a sample is positive
/// should be high on positive and low on negative data.
pub fn threshold_goodness_loss<T: Float>(
    tape: &mut Tape<T>,
    goodness_pos: Var,
    goodness_neg: Var,
    threshold: f64,
) -> Var {
    let below = tape.neg(goodness_pos);
    let below = tape.add_scalar(below, threshold);
    let below = tape.softplus(below);
    let above = tape.add_scalar(goodness_neg, -threshold);
    let above = tape.softplus(above);
    let (a, b) = (tape.mean(below), tape.mean(above));
    tape.add(a, b)
}

/// A paired objective: `mean_b softplus(β·(g⁻_b − g⁺_b))` for goodness vectors of shape `(B)`
/// whose entries `b` are the same input seen as positive and as negative: the probability
/// `σ(β·(g⁺ − g⁻))` that the positive is the better one should be high. No threshold to tune;
/// `β` sets how hard a pair already ordered keeps pushing.
pub fn pairwise_goodness_loss<T: Float>(
    tape: &mut Tape<T>,
    goodness_pos: Var,
    goodness_neg: Var,
    beta: f64,
) -> Var {
    let d = tape.sub(goodness_neg, goodness_pos);
    let d = tape.scale(d, beta);
    let d = tape.softplus(d);
    tape.mean(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two scopes in a chain: scope b's loss trains b's weight only, and scope a's weight gets
    /// exactly the gradient of a's own loss.
    #[test]
    fn no_gradient_crosses_a_scope() {
        let mut params = ParamStore::<f64>::new();
        let wa = params.add("a", Tensor::from_vec([2, 2], vec![0.5, -0.3, 0.2, 0.8]));
        let wb = params.add("b", Tensor::from_vec([2, 1], vec![1.5, -0.7]));
        let record = |tape: &mut Tape<f64>, local: bool| {
            let x = tape.constant(Tensor::from_vec([1, 2], vec![1.0, 2.0]));
            tape.enter_scope("a");
            let a = params.var(tape, wa);
            let h = tape.matmul(x, a);
            let la = tape.square(h);
            let la = tape.sum(la);
            tape.enter_scope("b");
            let b = params.var(tape, wb);
            let y = tape.matmul(h, b);
            let lb = tape.square(y);
            let lb = tape.sum(lb);
            if local {
                tape.declare_local_loss("a", la);
                tape.declare_local_loss("b", lb);
            }
            (la, lb)
        };
        let mut tape = Tape::new();
        let (_, lb) = record(&mut tape, true);
        let ff = ForwardForward::default().assign_credit(&mut tape, lb.into(), &params);
        // backprop of a's loss alone, and of b's loss with h held fixed
        let mut t2 = Tape::new();
        let (la, _) = record(&mut t2, false);
        let only_a = super::super::Backprop.assign_credit(&mut t2, la.into(), &params);
        assert_eq!(ff.get(wa), only_a.get(wa));
        let mut t3 = Tape::new();
        let (_, lb) = record(&mut t3, false);
        let full = super::super::Backprop.assign_credit(&mut t3, lb.into(), &params);
        assert_eq!(ff.get(wb), full.get(wb));
        // backprop of b's loss would also have reached a
        assert!(full.get(wa).unwrap().data().iter().any(|v| v.abs() > 1e-3));
    }

    #[test]
    fn goodness_losses_prefer_ordered_pairs() {
        let mut tape = Tape::<f64>::new();
        let hi = tape.constant(Tensor::from_vec([2], vec![3.0, 4.0]));
        let lo = tape.constant(Tensor::from_vec([2], vec![0.0, 1.0]));
        let good = threshold_goodness_loss(&mut tape, hi, lo, 2.0);
        let bad = threshold_goodness_loss(&mut tape, lo, hi, 2.0);
        assert!(tape.value(good).item() < tape.value(bad).item());
        let good = pairwise_goodness_loss(&mut tape, hi, lo, 1.0);
        let bad = pairwise_goodness_loss(&mut tape, lo, hi, 1.0);
        let expect = (1.0 + (-3.0f64).exp()).ln();
        assert!((tape.value(good).item() - expect).abs() < 1e-12);
        assert!(tape.value(bad).item() > 3.0);
    }
}
