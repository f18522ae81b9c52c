//! Learning rules: how one recorded forward pass becomes parameter updates.
//!
//! A model records its forward pass and loss on a tape; a [`LearningRule`] turns that record
//! into a [`ParamGrads`] (one tensor per trainable parameter); an
//! [`Optimizer`](crate::optim::Optimizer) applies it. Swapping the rule leaves model and
//! optimiser untouched:
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
//!     let grads = rule.assign_credit(&mut tape, loss, &params);
//!     opt.step(&mut params, &grads).unwrap();
//! }
//! ```
//!
//! Sign convention: what a rule returns is used like `∂L/∂θ`: optimisers *subtract* it.
//! Rules that keep state (fixed feedback weights, traces) own it; `assign_credit` takes
//! `&mut self`. Rules that change individual VJPs do so through
//! [`BackwardHooks`](crate::BackwardHooks), so the model's ops need not know about them.

mod feedback;
mod grads;

pub use feedback::FeedbackAlignment;
pub use grads::ParamGrads;

use crate::{Float, ParamStore, Tape, Var};

/// Credit assignment: one recorded forward pass (`tape`, scalar `loss`) → parameter gradients.
pub trait LearningRule<T: Float> {
    /// Writes the rule's gradient for every trainable parameter on `tape` into `grads`
    /// (replacing its contents, reusing its buffers). May run backward sweeps on `tape`.
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        loss: Var,
        params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    );

    /// Like [`LearningRule::assign_credit_into`], into a fresh [`ParamGrads`].
    fn assign_credit(
        &mut self,
        tape: &mut Tape<T>,
        loss: Var,
        params: &ParamStore<T>,
    ) -> ParamGrads<T> {
        let mut grads = ParamGrads::new();
        self.assign_credit_into(tape, loss, params, &mut grads);
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
        loss: Var,
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        tape.backward(loss);
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
        let g = Backprop.assign_credit(&mut tape, loss, &params);
        // L = (3·0.5 − 4)² → ∂L/∂w = 2·(−2.5)·(3, 4)
        assert_eq!(g.get(w).unwrap().data(), &[-15.0, -20.0]);
    }
}
