//! The built-in update rules: [`Sgd`] (with optional momentum) and [`Adam`].
//!
//! Each is a pure per-parameter rule: given the parameter, its gradient, its state slots, the
//! 1-based step count of *this parameter* and the learning rate of this step, update the
//! parameter in place. Arithmetic is in
//! the parameter's float type; Adam's bias corrections are computed in f64.

use super::UpdateRule;
use crate::{Float, Tensor};

/// Stochastic gradient descent: `v ← μ·v + g`, `θ ← θ − lr·v` (PyTorch's form; with `μ = 0`
/// this is `θ ← θ − lr·g` and keeps no state).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sgd {
    /// Momentum `μ` (0, the default: none).
    pub momentum: f64,
}

impl<T: Float> UpdateRule<T> for Sgd {
    fn name(&self) -> &'static str {
        "sgd"
    }
    fn slots(&self) -> &'static [&'static str] {
        if self.momentum != 0.0 {
            &["velocity"]
        } else {
            &[]
        }
    }
    fn update(&self, p: &mut [T], g: &[T], slots: &mut [Tensor<T>], _step: u64, lr: f64) {
        let lr = T::of(lr);
        match slots {
            [v] => {
                let mu = T::of(self.momentum);
                for ((p, &g), v) in p.iter_mut().zip(g).zip(v.data_mut()) {
                    *v = mu * *v + g;
                    *p -= lr * *v;
                }
            }
            _ => p.iter_mut().zip(g).for_each(|(p, &g)| *p -= lr * g),
        }
    }
}

/// Adam (Kingma & Ba 2015), as in PyTorch without weight decay:
/// `m ← β₁m + (1−β₁)g`, `v ← β₂v + (1−β₂)g²`,
/// `θ ← θ − lr · (m / (1−β₁ᵗ)) / (√(v / (1−β₂ᵗ)) + ε)`.
///
/// Defaults are the paper's and the authors' code's (docs/references.md#training: β (0.9,
/// 0.999), ε 1e-8, no weight decay; their learning rate, 1e-3, is the caller's to give).
#[derive(Clone, Copy, Debug)]
pub struct Adam {
    /// Decay of the first-moment average.
    pub beta1: f64,
    /// Decay of the second-moment average.
    pub beta2: f64,
    /// Added to `√v̂` in the denominator.
    pub eps: f64,
}

impl Default for Adam {
    fn default() -> Self {
        Adam {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
        }
    }
}

impl<T: Float> UpdateRule<T> for Adam {
    fn name(&self) -> &'static str {
        "adam"
    }
    fn slots(&self) -> &'static [&'static str] {
        &["m", "v"]
    }
    fn update(&self, p: &mut [T], g: &[T], slots: &mut [Tensor<T>], step: u64, lr: f64) {
        let [m, v] = slots else {
            panic!("adam: expects slots m, v")
        };
        let t = step.max(1) as i32;
        let bc1 = 1.0 - self.beta1.powi(t);
        let bc2 = 1.0 - self.beta2.powi(t);
        // θ −= (lr/bc1) · m / (√v / √bc2 + ε), PyTorch's arrangement.
        let step_size = T::of(lr / bc1);
        let inv_sqrt_bc2 = T::of(1.0 / bc2.sqrt());
        let (b1, b2, eps) = (T::of(self.beta1), T::of(self.beta2), T::of(self.eps));
        let (c1, c2) = (T::one() - b1, T::one() - b2);
        for (((p, &g), m), v) in p.iter_mut().zip(g).zip(m.data_mut()).zip(v.data_mut()) {
            *m = b1 * *m + c1 * g;
            *v = b2 * *v + c2 * g * g;
            *p -= step_size * *m / (v.sqrt() * inv_sqrt_bc2 + eps);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adam_first_step_moves_by_lr_times_sign() {
        // With m̂ = g and v̂ = g² on step 1, the update is lr·g/(|g| + ε) ≈ lr·sign(g).
        let rule = Adam::default();
        let mut p = vec![1.0f64, 1.0, 1.0];
        let g = [3.0, -0.5, 1e-3];
        let mut slots = vec![Tensor::zeros([3]), Tensor::zeros([3])];
        rule.update(&mut p, &g, &mut slots, 1, 0.01);
        for (i, &gi) in g.iter().enumerate() {
            let want = 1.0 - 0.01 * gi / (gi.abs() + 1e-8);
            assert!((p[i] - want).abs() < 1e-12, "{i}: {} vs {want}", p[i]);
        }
        assert!((slots[0].data()[0] - 0.3).abs() < 1e-12);
        assert!((slots[1].data()[0] - 0.009).abs() < 1e-12);
    }

    #[test]
    fn adam_matches_a_hand_computed_second_step() {
        let rule = Adam::default();
        let mut p = vec![0.5f64];
        let mut s = vec![Tensor::zeros([1]), Tensor::zeros([1])];
        rule.update(&mut p, &[2.0], &mut s, 1, 1e-3);
        rule.update(&mut p, &[-1.0], &mut s, 2, 1e-3);
        let (m, v) = (0.9 * 0.2 - 0.1, 0.999 * 0.004 + 0.001 * 1.0);
        let (mh, vh) = (m / (1.0 - 0.81), v / (1.0 - 0.999f64.powi(2)));
        let p1 = 0.5 - 1e-3 * 2.0 / (2.0 + 1e-8); // step 1: m̂ = 2, v̂ = 4
        let want = p1 - 1e-3 * mh / (vh.sqrt() + 1e-8);
        assert!((p[0] - want).abs() < 1e-12, "{} vs {want}", p[0]);
    }

    #[test]
    fn the_step_scales_with_the_learning_rate() {
        let rule = Adam::default();
        let (mut a, mut b) = (vec![0.5f64], vec![0.5f64]);
        let mut sa = vec![Tensor::zeros([1]), Tensor::zeros([1])];
        let mut sb = vec![Tensor::zeros([1]), Tensor::zeros([1])];
        for (step, g) in [(1, 2.0), (2, -1.0), (3, 0.5)] {
            rule.update(&mut a, &[g], &mut sa, step, 1e-3);
            rule.update(&mut b, &[g], &mut sb, step, 1e-2);
        }
        assert!(((b[0] - 0.5) - 10.0 * (a[0] - 0.5)).abs() < 1e-12);
        let sgd = Sgd::default();
        let mut p = vec![0.0f64];
        sgd.update(&mut p, &[1.0], &mut [], 1, 0.3);
        assert!((p[0] + 0.3).abs() < 1e-12);
    }

    #[test]
    fn sgd_momentum_accumulates_velocity() {
        let rule = Sgd { momentum: 0.9 };
        let mut p = vec![0.0f32];
        let mut s = vec![Tensor::zeros([1])];
        assert_eq!(<Sgd as UpdateRule<f32>>::slots(&rule), &["velocity"]);
        rule.update(&mut p, &[1.0], &mut s, 1, 0.1);
        rule.update(&mut p, &[1.0], &mut s, 2, 0.1);
        // v: 1, 1.9; p: -0.1, -0.29
        assert!((p[0] + 0.29).abs() < 1e-6);
    }
}
