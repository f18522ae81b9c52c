//! Learning rules: how one recorded forward pass becomes parameter updates.
//!
//! A model records its forward pass on a tape and hands the rule an [`Objective`]: the global
//! scalar loss and, optionally, the output it is computed from. On the same tape the model
//! names what rules that act on layers need ([`crate::scopes`]): scopes (stretches of the
//! tape, e.g. one per layer or bucket), tagged activations (layer outputs) and local losses
//! (one scalar objective per scope). A [`LearningRule`] turns that record into a
//! [`ParamGrads`] (one tensor per trainable parameter); an
//! [`Optimizer`](crate::optim::Optimizer) applies it. Swapping the rule leaves model and
//! optimiser untouched.
//!
//! | rule | reads | credit | state |
//! |---|---|---|---|
//! | [`Backprop`] | loss | exact `∂L/∂θ` | none |
//! | [`FeedbackAlignment`] | loss, scopes | errors sent back through backward weights `B` ([`FeedbackScheme`]: random, sign-concordant, norm-matched, Kolen–Pollack) | `B`'s magnitudes, steps |
//! | [`DirectFeedbackAlignment`] | loss, output, tags, scopes | the output error sent by a fixed random projection to every tagged layer | the projections |
//! | [`ForwardForward`] | local losses, scopes | each scope's own objective ([`LocalObjective`]: goodness or a local prediction), nothing across scopes | none |
//!
//! How close a rule's credit is to backprop's is a measurement, not a belief:
//! [`alignment`] runs one more backprop sweep on the same tape and compares, per group of
//! parameters (the cortex: per bucket), the cosine and the norms.
//!
//! A rule that needs local losses says so ([`LearningRule::needs_local_losses`]); a model
//! records them only then, so other rules pay nothing for them. Backward time per scope is
//! measured by the tape for every rule ([`crate::Tape::scope_times`]).
//!
//! ```
//! use autodiff::{learn::{Backprop, FeedbackAlignment, LearningRule}, optim::{Adam, Optimizer}};
//! use autodiff::{ParamStore, Tape, Tensor};
//!
//! let mut params = ParamStore::<f32>::new();
//! let w = params.add("w", Tensor::from_vec([2, 1], vec![0.3, -0.2]));
//! let use_fa = true;
//! let mut rule: Box<dyn LearningRule<f32>> =
//!     if use_fa { Box::new(FeedbackAlignment::new(7)) } else { Box::new(Backprop) };
//! let mut opt = Optimizer::new(Adam::default());
//! let mut tape = Tape::new();
//! for _ in 0..3 {
//!     tape.clear();
//!     let x = tape.constant(Tensor::from_vec([1, 2], vec![1.0, 2.0]));
//!     let wv = params.var(&mut tape, w);
//!     let y = tape.matmul(x, wv);
//!     let loss = tape.sum(y);
//!     let grads = rule.assign_credit(&mut tape, loss.into(), &params);
//!     opt.step(1e-3, &mut params, &grads).unwrap();
//! }
//! ```
//!
//! Sign convention: what a rule returns is used like `∂L/∂θ`: optimisers *subtract* it.
//! Rules that keep state (fixed feedback weights, traces) own it; `assign_credit` takes
//! `&mut self`, and [`LearningRule::state`] / [`LearningRule::load_state`] hand it to a
//! checkpoint and back ([`RuleState`]), so that a resumed run is the run that never stopped. Rules that change individual VJPs do so through
//! [`BackwardHooks`](crate::BackwardHooks), so the model's ops need not know about them.

pub mod alignment;
pub mod direct_feedback;
pub mod feedback;
mod forward_forward;
mod grads;
mod state;

pub use alignment::{AlignmentMeter, GroupAlignment};
pub use direct_feedback::DirectFeedbackAlignment;
pub use feedback::{FeedbackAlignment, FeedbackScheme};
pub use forward_forward::{
    pairwise_goodness_loss, threshold_goodness_loss, ForwardForward, LocalObjective,
};
pub use grads::ParamGrads;
pub use state::{RuleState, RuleStateError};

use crate::{Float, ParamStore, Tape, Var};

/// What a model hands a rule besides the tape: its global objective.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Objective {
    /// The scalar training loss.
    pub loss: Var,
    /// The network's output the loss is computed from, for rules that project the output
    /// error `∂L/∂output` ([`DirectFeedbackAlignment`]).
    pub output: Option<Var>,
}

impl Objective {
    /// The objective `loss` with its output `output`.
    pub fn with_output(loss: Var, output: Var) -> Self {
        Objective {
            loss,
            output: Some(output),
        }
    }
}

impl From<Var> for Objective {
    fn from(loss: Var) -> Self {
        Objective { loss, output: None }
    }
}

/// Credit assignment: one recorded forward pass (`tape`, [`Objective`]) → parameter gradients.
pub trait LearningRule<T: Float> {
    /// Writes the rule's gradient for every trainable parameter on `tape` into `grads`
    /// (replacing its contents, reusing its buffers). May run backward sweeps on `tape`.
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    );

    /// Whether the model must declare local losses ([`Tape::declare_local_loss`]) for this
    /// rule; models record them only when asked.
    fn needs_local_losses(&self) -> bool {
        false
    }

    /// Which local losses the model should declare when [`LearningRule::needs_local_losses`]
    /// ([`LocalObjective`]; the goodness of forward-forward unless the rule says otherwise).
    fn local_objective(&self) -> LocalObjective {
        LocalObjective::Goodness
    }

    /// The rule's state for a checkpoint (see [`RuleState`]); empty for a rule that keeps
    /// none.
    fn state(&self, _params: &ParamStore<T>) -> RuleState<T> {
        RuleState::new()
    }

    /// Restores a state written by [`LearningRule::state`] of the same rule for the same
    /// parameters. A rule that keeps no state accepts only an empty one.
    fn load_state(
        &mut self,
        state: &RuleState<T>,
        _params: &ParamStore<T>,
    ) -> Result<(), RuleStateError> {
        if state.is_empty() {
            Ok(())
        } else {
            Err(state.unexpected("this rule"))
        }
    }

    /// Like [`LearningRule::assign_credit_into`], into a fresh [`ParamGrads`].
    fn assign_credit(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        params: &ParamStore<T>,
    ) -> ParamGrads<T> {
        let mut grads = ParamGrads::new();
        self.assign_credit_into(tape, objective, params, &mut grads);
        grads
    }
}

/// Backpropagation: the exact gradient `∂L/∂θ` from one reverse sweep.
#[derive(Clone, Copy, Debug, Default)]
pub struct Backprop;

impl<T: Float> LearningRule<T> for Backprop {
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        tape.backward(objective.loss);
        grads.fill_from_tape(tape);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Tensor;

    #[test]
    fn backprop_returns_the_tape_gradients() {
        let mut params = ParamStore::<f64>::new();
        let w = params.add("w", Tensor::from_vec([2, 1], vec![0.5, -1.0]));
        let mut tape = Tape::new();
        let x = tape.constant(Tensor::from_vec([1, 2], vec![3.0, 4.0]));
        let wv = params.var(&mut tape, w);
        let y = tape.matmul(x, wv);
        let loss = tape.square(y);
        let loss = tape.sum(loss);
        let g = Backprop.assign_credit(&mut tape, loss.into(), &params);
        // L = (3·0.5 − 4)² → ∂L/∂w = 2·(−2.5)·(3, 4)
        assert_eq!(g.get(w).unwrap().data(), &[-15.0, -20.0]);
    }
}
