//! Neural Scope: the least-squares affine map from N-dimensional percepts to linear sRGB
//! (paper §5; authors' code, docs/references.md#neural-scope).
//!
//! `rgb = W·p + b`, `W` is `(3 × N)` row-major, fitted in closed form on (percept, linear sRGB)
//! pairs — the optimum the official code reaches online with Adam. The fit accumulates the normal
//! equations `[P 1]ᵀ[P 1]` and `[P 1]ᵀ·RGB` (so any number of pixels can stream through
//! [`ScopeAccumulator::add_batch`] with O(N²) memory), then solves them with a thin SVD and a
//! relative cut-off, giving the minimum-norm solution when percept channels are linearly
//! dependent (e.g. dead channels early in training).
//!
//! Targets: linear sRGB of the scene's spectra computed through CIE 1931 XYZ
//! ([`linear_srgb_of_radiance`]).

use crate::cie::CieObserver;
use crate::error::{ColorimetryError, Result};
use crate::linalg::lstsq;
use crate::srgb::xyz_to_linear_srgb;

/// Relative singular-value cut-off for the normal equations (their condition number is the
/// square of the data's).
pub const SCOPE_RCOND: f64 = 1e-13;

/// A fitted Neural Scope.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NeuralScope {
    /// Percept dimension N.
    pub n_inputs: usize,
    /// `(3 × N)` row-major.
    pub weights: Vec<f64>,
    /// Bias per R, G, B.
    pub bias: [f64; 3],
    /// Rank of the augmented design matrix.
    pub rank: usize,
    /// Number of samples fitted.
    pub n_samples: usize,
}

/// Streaming normal equations for [`NeuralScope`].
#[derive(Debug, Clone, PartialEq)]
pub struct ScopeAccumulator {
    n: usize,
    /// `(N+1) × (N+1)`.
    xtx: Vec<f64>,
    /// `(N+1) × 3`.
    xty: Vec<f64>,
    count: usize,
}

impl ScopeAccumulator {
    /// Empty accumulator for N-dimensional percepts.
    pub fn new(n_inputs: usize) -> Self {
        let m = n_inputs + 1;
        ScopeAccumulator {
            n: n_inputs,
            xtx: vec![0.0; m * m],
            xty: vec![0.0; m * 3],
            count: 0,
        }
    }

    /// Add `percepts` (row-major `(B × N)`) with targets `rgb` (row-major `(B × 3)`).
    ///
    /// # Panics
    /// If the lengths do not describe the same B.
    pub fn add_batch(&mut self, percepts: &[f64], rgb: &[f64]) {
        let (n, m) = (self.n, self.n + 1);
        assert!(
            percepts.len().is_multiple_of(n.max(1)) && percepts.len() / n.max(1) * 3 == rgb.len(),
            "ScopeAccumulator::add_batch: {} percept values (N = {n}) vs {} rgb values",
            percepts.len(),
            rgb.len()
        );
        let mut x = vec![0.0; m];
        for (p, t) in percepts.chunks_exact(n.max(1)).zip(rgb.chunks_exact(3)) {
            x[..n].copy_from_slice(&p[..n]);
            x[n] = 1.0;
            for i in 0..m {
                let xi = x[i];
                for j in i..m {
                    self.xtx[i * m + j] += xi * x[j];
                }
                for c in 0..3 {
                    self.xty[i * 3 + c] += xi * t[c];
                }
            }
            self.count += 1;
        }
    }

    /// Solve. Error if no samples were added.
    pub fn finish(&self) -> Result<NeuralScope> {
        if self.count == 0 {
            return Err(ColorimetryError::setting(
                "neural scope",
                "no (percept, rgb) samples to fit",
            ));
        }
        let (n, m) = (self.n, self.n + 1);
        let mut a = self.xtx.clone();
        for i in 0..m {
            for j in 0..i {
                a[i * m + j] = a[j * m + i];
            }
        }
        let sol = lstsq(&a, m, m, &self.xty, 3, SCOPE_RCOND);
        let mut weights = vec![0.0; 3 * n];
        for c in 0..3 {
            for i in 0..n {
                weights[c * n + i] = sol.x[i * 3 + c];
            }
        }
        let bias = [sol.x[n * 3], sol.x[n * 3 + 1], sol.x[n * 3 + 2]];
        Ok(NeuralScope {
            n_inputs: n,
            weights,
            bias,
            rank: sol.rank,
            n_samples: self.count,
        })
    }
}

impl NeuralScope {
    /// Fit on `percepts` (row-major `(B × N)`) and linear sRGB `targets` (`(B × 3)`).
    pub fn fit(percepts: &[f64], targets: &[f64], n_inputs: usize) -> Result<NeuralScope> {
        let mut acc = ScopeAccumulator::new(n_inputs);
        acc.add_batch(percepts, targets);
        acc.finish()
    }

    /// Linear sRGB of one percept.
    pub fn apply(&self, percept: &[f64]) -> [f64; 3] {
        let n = self.n_inputs;
        assert_eq!(
            percept.len(),
            n,
            "NeuralScope::apply: percept {} vs N {n}",
            percept.len()
        );
        std::array::from_fn(|c| {
            self.bias[c]
                + (0..n)
                    .map(|i| self.weights[c * n + i] * percept[i])
                    .sum::<f64>()
        })
    }

    /// Apply to a row-major `(B × N)` batch, writing `(B × 3)` into `out`.
    pub fn apply_batch(&self, percepts: &[f64], out: &mut [f64]) {
        let n = self.n_inputs.max(1);
        assert_eq!(
            percepts.len() / n * 3,
            out.len(),
            "NeuralScope::apply_batch: output length"
        );
        for (p, o) in percepts.chunks_exact(n).zip(out.chunks_exact_mut(3)) {
            o.copy_from_slice(&self.apply(p));
        }
    }

    /// Root-mean-square error over all channels on a batch.
    pub fn rmse(&self, percepts: &[f64], targets: &[f64]) -> f64 {
        let mut out = vec![0.0; targets.len()];
        self.apply_batch(percepts, &mut out);
        (out.iter()
            .zip(targets)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / targets.len().max(1) as f64)
            .sqrt()
    }
}

/// Linear sRGB of a radiance spectrum through CIE 1931 XYZ, scaled so that a radiance whose Y
/// equals `white_y` (`Σ L·ȳ·Δλ` of the scene white) has Y = 1.
pub fn linear_srgb_of_radiance(observer: &CieObserver, radiance: &[f64], white_y: f64) -> [f64; 3] {
    let xyz = observer.xyz_of_radiance(radiance);
    xyz_to_linear_srgb(xyz.map(|v| v / white_y))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn synthetic(n: usize, b: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>, [f64; 3]) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let w: Vec<f64> = (0..3 * n).map(|_| rng.random_range(-2.0..2.0)).collect();
        let bias = [0.1, -0.3, 0.7];
        let p: Vec<f64> = (0..b * n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut t = vec![0.0; b * 3];
        for s in 0..b {
            for c in 0..3 {
                t[s * 3 + c] = bias[c] + (0..n).map(|i| w[c * n + i] * p[s * n + i]).sum::<f64>();
            }
        }
        (p, t, w, bias)
    }

    #[test]
    fn recovers_a_known_affine_map_exactly() {
        let (p, t, w, bias) = synthetic(8, 500, 1);
        let s = NeuralScope::fit(&p, &t, 8).unwrap();
        assert_eq!(s.rank, 9);
        for (a, b) in s.weights.iter().zip(&w) {
            assert!((a - b).abs() < 1e-10, "{a} vs {b}");
        }
        for (a, b) in s.bias.iter().zip(bias) {
            assert!((a - b).abs() < 1e-10);
        }
        assert!(s.rmse(&p, &t) < 1e-10);
    }

    #[test]
    fn streaming_equals_one_batch_and_dependent_channels_are_handled() {
        let (p, t, _, _) = synthetic(4, 300, 2);
        let mut acc = ScopeAccumulator::new(4);
        acc.add_batch(&p[..400], &t[..300]);
        acc.add_batch(&p[400..], &t[300..]);
        let a = acc.finish().unwrap();
        let b = NeuralScope::fit(&p, &t, 4).unwrap();
        assert!(a
            .weights
            .iter()
            .zip(&b.weights)
            .all(|(x, y)| (x - y).abs() < 1e-10));
        // duplicate a channel: still an exact fit, rank one less
        let p5: Vec<f64> = p
            .chunks_exact(4)
            .flat_map(|r| [r[0], r[1], r[2], r[3], r[3]])
            .collect();
        let s = NeuralScope::fit(&p5, &t, 5).unwrap();
        assert_eq!(s.rank, 5);
        assert!(s.rmse(&p5, &t) < 1e-9);
        assert!(ScopeAccumulator::new(3).finish().is_err());
    }
}
