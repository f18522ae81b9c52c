//! The feedback schemes of [`super::FeedbackAlignment`]: how the backward weight `B` of a
//! forward weight `W` is made, and the random draws behind it.
//!
//! Every scheme keeps one *magnitude* tensor `M` per weight, drawn at the weight's first use
//! (and saved in the rule's state), and builds `B` from it at every step:
//!
//! | scheme | `M` | `B` | source |
//! |---|---|---|---|
//! | [`FeedbackScheme::Random`] | `R ~ N(0, σ²)` | `R` | Lillicrap et al. 2016, *Nat. Commun.* 7:13276 |
//! | [`FeedbackScheme::UniformSign`] (uSF) | `σ` (one number) | `σ·sign(W)` | Liao, Leibo & Poggio 2016, AAAI ("sign symmetry") |
//! | [`FeedbackScheme::BatchRandomSign`] (brSF) | `σ` | `|R_t| ⊙ sign(W)`, `R_t ~ N(0, σ²)` redrawn every step | Liao et al. 2016 |
//! | [`FeedbackScheme::FixedRandomSign`] (frSF) | `|R|` | `|R| ⊙ sign(W)` | Liao et al. 2016 |
//! | [`FeedbackScheme::KolenPollack`] | `B`, learned ([`super::kolen_pollack`]) | `B` | Kolen & Pollack 1994; Akrout et al. 2019, NeurIPS |
//!
//! `sign(0) = 0`, so sign-concordant feedback has `sign(B) = sign(W)` at every element, a
//! zero weight included (it sends nothing back). `σ` is the scale of the weight: the RMS of
//! `W` where it is first used (or in the parameters the training started from,
//! [`super::FeedbackAlignment::scaled_to`]); for an all-zero `W`, `1/√fan_in` (`fan_in =
//! dims[0]` for an `(in, out)` matmul weight, `numel / dims[0]` for an `(out, in, kh, kw)`
//! kernel). The sign-concordant schemes of the biotorch benchmark (Sanfiz & Akrout 2021) use
//! magnitude 1 or Xavier's `√(2/(fan_in + fan_out))`; scaling to the weight instead keeps the
//! error's size through a layer as backprop's at the start, for every scheme alike.
//!
//! Two modifiers apply to any scheme, in this order: *norm matching* rescales `B` at every
//! step to `‖B‖_F = ‖W‖_F` (the current `W`; nothing is sent back through an all-zero `W`),
//! and a *sign flip* sends `−B` (a control: feedback that points the wrong way).
//!
//! Kolen–Pollack learns `B` from `W`'s own update with weight decay on both: see
//! [`super::kolen_pollack`].

use crate::{Float, ParamId, Tensor};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// How `B` is made from `W` (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum FeedbackScheme {
    /// Fixed random Gaussian `B`.
    #[default]
    Random,
    /// `σ·sign(W)`: uniform sign-concordant feedback (uSF).
    UniformSign,
    /// `|R_t| ⊙ sign(W)`, `R_t` redrawn every step (brSF).
    BatchRandomSign,
    /// `|R| ⊙ sign(W)`, `R` fixed (frSF).
    FixedRandomSign,
    /// `B` learned by the update of `W` with weight decay ([`super::kolen_pollack`]).
    KolenPollack {
        /// `η` of `B`'s update.
        learning_rate: f64,
        /// `λ`, applied to both `W` and `B`.
        weight_decay: f64,
        /// How `B` is trained.
        optimizer: super::kolen_pollack::KolenPollackOptimizer,
    },
}

impl FeedbackScheme {
    /// The short name used in rule states and configs: `random`, `usf`, `brsf`, `frsf`,
    /// `kolen-pollack`.
    pub fn name(&self) -> &'static str {
        match self {
            FeedbackScheme::Random => "random",
            FeedbackScheme::UniformSign => "usf",
            FeedbackScheme::BatchRandomSign => "brsf",
            FeedbackScheme::FixedRandomSign => "frsf",
            FeedbackScheme::KolenPollack { .. } => "kolen-pollack",
        }
    }

    /// Whether `B` follows the sign of `W`.
    pub fn is_sign_concordant(&self) -> bool {
        matches!(
            self,
            FeedbackScheme::UniformSign
                | FeedbackScheme::BatchRandomSign
                | FeedbackScheme::FixedRandomSign
        )
    }

    /// The magnitude tensor `M` of a weight shaped like `w`, with scale `sigma`, drawn from
    /// the stream `(seed, id, 0)`.
    pub(super) fn draw_magnitude<T: Float>(
        &self,
        w: &Tensor<T>,
        sigma: f64,
        seed: u64,
        id: ParamId,
    ) -> Tensor<T> {
        match self {
            FeedbackScheme::Random | FeedbackScheme::KolenPollack { .. } => {
                gaussian(w, sigma, stream(seed, id, 0))
            }
            FeedbackScheme::FixedRandomSign => {
                let mut r = gaussian(w, sigma, stream(seed, id, 0));
                r.data_mut().iter_mut().for_each(|v| *v = v.abs());
                r
            }
            FeedbackScheme::UniformSign | FeedbackScheme::BatchRandomSign => {
                Tensor::from_vec([1], vec![T::of(sigma)])
            }
        }
    }

    /// `B` at step `step` (0-based) from the magnitude `m` and the current weight `w`, before
    /// the modifiers.
    pub(super) fn feedback<T: Float>(
        &self,
        m: &Tensor<T>,
        w: &Tensor<T>,
        seed: u64,
        id: ParamId,
        step: u64,
    ) -> Tensor<T> {
        match self {
            FeedbackScheme::Random | FeedbackScheme::KolenPollack { .. } => m.clone(),
            FeedbackScheme::UniformSign => {
                let s = m.data()[0];
                Tensor::from_fn(w.shape(), |i| sign(w.data()[i]) * s)
            }
            FeedbackScheme::BatchRandomSign => {
                let r = gaussian(w, m.data()[0].as_f64(), stream(seed, id, step + 1));
                Tensor::from_fn(w.shape(), |i| sign(w.data()[i]) * r.data()[i].abs())
            }
            FeedbackScheme::FixedRandomSign => {
                Tensor::from_fn(w.shape(), |i| sign(w.data()[i]) * m.data()[i])
            }
        }
    }
}

/// `1`, `−1` or `0` (not `f32::signum`, which gives `1` at zero).
pub fn sign<T: Float>(x: T) -> T {
    if x > T::zero() {
        T::one()
    } else if x < T::zero() {
        -T::one()
    } else {
        T::zero()
    }
}

/// `σ` of the feedback of weight `w` (module docs).
pub(super) fn scale<T: Float>(w: &Tensor<T>) -> f64 {
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

/// Seed of draw `k` of parameter `id`: SplitMix-style mixing, so neighbouring ids and draws get
/// unrelated streams.
fn stream(seed: u64, id: ParamId, k: u64) -> u64 {
    let mut s = seed ^ (u64::from(id.0) + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    s ^= k.wrapping_mul(0xD1B5_4A32_D192_ED03);
    s = (s ^ (s >> 31)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    s ^ (s >> 29)
}

/// `N(0, σ²)` samples shaped like `w`.
fn gaussian<T: Float>(w: &Tensor<T>, sigma: f64, seed: u64) -> Tensor<T> {
    let mut rng = StdRng::seed_from_u64(seed);
    Tensor::from_fn(w.shape(), |_| {
        let z: f64 = StandardNormal.sample(&mut rng);
        T::of(sigma * z)
    })
}

/// Rescales `b` to the Frobenius norm of `w` (zero when either is zero).
pub(super) fn match_norm<T: Float>(b: &mut Tensor<T>, w: &Tensor<T>) {
    let (nb, nw) = (b.sum_sq().sqrt(), w.sum_sq().sqrt());
    let c = if nb > 0.0 { T::of(nw / nb) } else { T::zero() };
    b.data_mut().iter_mut().for_each(|v| *v *= c);
}
