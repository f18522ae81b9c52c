//! Kolen–Pollack's learning of the backward weight `B` (Kolen & Pollack 1994; Akrout et al.
//! 2019, NeurIPS, "Deep learning without weight transport"): `B` receives the update `W`
//! receives, computed from the same local signal, with weight decay on both.
//!
//! With `g = ∂L/∂W` as the rule computes it (the error having come down through the layers'
//! `B`s), the rule returns `g + λ·W` for `W` and updates `B` by the same optimiser on
//! `g + λ·B`:
//! - [`KolenPollackOptimizer::Sgd`]: `B ← B − η·(g + λ·B)`. Trained by SGD with learning rate
//!   `η`, `W` and `B` then receive the same update and the same decay, and `W − B` shrinks by
//!   exactly `(1 − ηλ)` per step (Akrout et al., eq. 2–3).
//! - [`KolenPollackOptimizer::Adam`]: Adam (β₁ 0.9, β₂ 0.999, ε 1e-8, learning rate `η`) with
//!   moments of its own, as when `B` is a parameter in the same Adam as `W` (a PyTorch
//!   implementation of the rule). Trained by that Adam, `W` and `B` take identical steps when
//!   `λ = 0` (the same gradients, the same moments), so `W − B` keeps its start value; with
//!   `λ > 0` the decay makes them approach, not exactly by `(1 − ηλ)`. This is the choice for
//!   a model trained by Adam: an SGD step of `B` on raw gradients can be many times larger
//!   than Adam's bounded step of `W`, and `B` then outgrows the weight it should track.
//!
//! Adam's moments and step counts are part of the rule's state.

use crate::optim::{Adam, UpdateRule};
use crate::{Float, Tensor};

/// How `B` is trained (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum KolenPollackOptimizer {
    /// Plain SGD: exact Kolen–Pollack for a model trained by SGD at the same rate.
    Sgd,
    /// Adam with moments of its own, for a model trained by Adam.
    #[default]
    Adam,
}

/// Adam's moments of one `B`.
#[derive(Clone, Debug, PartialEq)]
pub struct Moments<T: Float> {
    /// First moment, shaped like `B`.
    pub m: Tensor<T>,
    /// Second moment, shaped like `B`.
    pub v: Tensor<T>,
    /// Updates done.
    pub steps: u64,
}

impl<T: Float> Moments<T> {
    /// Zero moments for a `B` shaped like `b`.
    pub fn zeros(b: &Tensor<T>) -> Self {
        Moments {
            m: Tensor::zeros(b.shape()),
            v: Tensor::zeros(b.shape()),
            steps: 0,
        }
    }
}

/// One step of `B` from `W`'s gradient `g` (module docs); `moments` is used by Adam only.
pub(super) fn step<T: Float>(
    optimizer: KolenPollackOptimizer,
    b: &mut Tensor<T>,
    g: &Tensor<T>,
    moments: &mut Moments<T>,
    learning_rate: f64,
    weight_decay: f64,
) {
    let decay = T::of(weight_decay);
    match optimizer {
        KolenPollackOptimizer::Sgd => {
            let eta = T::of(learning_rate);
            for (b, &g) in b.data_mut().iter_mut().zip(g.data()) {
                *b -= eta * (g + decay * *b);
            }
        }
        KolenPollackOptimizer::Adam => {
            let decayed: Vec<T> = (g.data().iter().zip(b.data()))
                .map(|(&g, &b)| g + decay * b)
                .collect();
            moments.steps += 1;
            let mut slots = [
                std::mem::replace(&mut moments.m, Tensor::zeros([0])),
                std::mem::replace(&mut moments.v, Tensor::zeros([0])),
            ];
            Adam::default().update(
                b.data_mut(),
                &decayed,
                &mut slots,
                moments.steps,
                learning_rate,
            );
            let [m, v] = slots;
            (moments.m, moments.v) = (m, v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optim::Optimizer;
    use crate::{ParamId, ParamStore};

    #[test]
    fn adam_gives_b_the_step_w_gets_from_the_same_adam() {
        let g = Tensor::from_fn([3, 2], |i| (i as f64 * 1.3).sin());
        let mut params = ParamStore::<f64>::new();
        params.add("w", Tensor::from_fn([3, 2], |i| (i as f64 * 0.7).cos()));
        let mut b = params.get(ParamId(0)).clone();
        let mut moments = Moments::zeros(&b);
        let mut opt = Optimizer::new(Adam::default());
        let mut grads = crate::learn::ParamGrads::new();
        for k in 0..5 {
            let gk = Tensor::from_fn([3, 2], |i| g.data()[i] * (1.0 + k as f64));
            grads.insert(ParamId(0), gk.clone());
            opt.step(0.01, &mut params, &grads).unwrap();
            step(
                KolenPollackOptimizer::Adam,
                &mut b,
                &gk,
                &mut moments,
                0.01,
                0.0,
            );
        }
        assert_eq!(&b, params.get(ParamId(0)), "λ = 0: identical steps");
        assert_eq!(moments.steps, 5);
    }
}
