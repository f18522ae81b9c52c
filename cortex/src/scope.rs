//! Neural Scope, online (paper §5; authors' code, docs/references.md#neural-scope): a least-squares map from the N-channel
//! percept to linear sRGB (with bias), fitted on **detached** percepts. Evaluation only: the
//! cortex never learns from it; the trainer hands out the last percept
//! ([`crate::Trainer::last_percept`]) and the caller, who knows the scene, supplies the target.
//!
//! The official NS is a zero-initialised linear layer trained by Adam alongside the cortex; this
//! is its optimum, computed exactly from running sums: `Sxx = Σ x̃x̃ᵀ`, `Sxy = Σ x̃yᵀ` with
//! `x̃ = (x, 1)`, each decayed by `forgetting` per update so the fit follows a cortex that is
//! still learning; the solution is `A = (Sxx + λI)⁻¹ Sxy` (tiny ridge λ for rank-deficient
//! percepts, e.g. at step 0 when every channel but one is zero).
//!
//! Layouts: percepts `(B, N, n, n)`, targets `(B, K, n, n)` (K = 3 for sRGB), row-major.
//! Pixels within `border_px` of the edge are ignored, like the loss.

/// The running least-squares fit.
#[derive(Clone, Debug)]
pub struct NeuralScope {
    n_in: usize,
    n_out: usize,
    sxx: Vec<f64>,
    sxy: Vec<f64>,
    /// Multiplier applied to the sums before each update (1 = plain accumulation).
    pub forgetting: f64,
    /// Ridge λ, relative to the mean diagonal of Sxx.
    pub ridge: f64,
    /// Pixels dropped at each edge.
    pub border_px: usize,
}

impl NeuralScope {
    /// A scope from `n_in` percept channels to `n_out` colour channels.
    pub fn new(n_in: usize, n_out: usize, border_px: usize) -> Self {
        let d = n_in + 1;
        NeuralScope {
            n_in,
            n_out,
            sxx: vec![0.0; d * d],
            sxy: vec![0.0; d * n_out],
            forgetting: 0.99,
            ridge: 1e-6,
            border_px,
        }
    }

    /// Adds a batch: `percept (B, n_in, h, w)` and `target (B, n_out, h, w)`.
    pub fn update(&mut self, percept: &[f32], target: &[f32], batch: usize, h: usize, w: usize) {
        let (ni, no, d) = (self.n_in, self.n_out, self.n_in + 1);
        assert_eq!(
            percept.len(),
            batch * ni * h * w,
            "NeuralScope::update: percept has {} values, want (B={batch}, {ni}, {h}, {w})",
            percept.len()
        );
        assert_eq!(
            target.len(),
            batch * no * h * w,
            "NeuralScope::update: target has {} values, want (B={batch}, {no}, {h}, {w})",
            target.len()
        );
        self.sxx
            .iter_mut()
            .chain(self.sxy.iter_mut())
            .for_each(|v| *v *= self.forgetting);
        let hw = h * w;
        let bp = self.border_px;
        let mut x = vec![0.0f64; d];
        for b in 0..batch {
            for yy in bp..h.saturating_sub(bp) {
                for xx in bp..w.saturating_sub(bp) {
                    let p = yy * w + xx;
                    for c in 0..ni {
                        x[c] = percept[(b * ni + c) * hw + p] as f64;
                    }
                    x[ni] = 1.0;
                    for i in 0..d {
                        for j in 0..d {
                            self.sxx[i * d + j] += x[i] * x[j];
                        }
                        for k in 0..no {
                            self.sxy[i * no + k] += x[i] * target[(b * no + k) * hw + p] as f64;
                        }
                    }
                }
            }
        }
    }

    /// The fitted map, `(n_in + 1) × n_out` row-major (last row: bias). Zero before any data.
    pub fn weights(&self) -> Vec<f64> {
        let (d, no) = (self.n_in + 1, self.n_out);
        let mean_diag = (0..d).map(|i| self.sxx[i * d + i]).sum::<f64>() / d as f64;
        if mean_diag <= 0.0 {
            return vec![0.0; d * no];
        }
        let mut a = self.sxx.clone();
        for i in 0..d {
            a[i * d + i] += self.ridge * mean_diag;
        }
        // Cholesky A = L Lᵀ
        let mut l = vec![0.0; d * d];
        for i in 0..d {
            for j in 0..=i {
                let mut s = a[i * d + j];
                for k in 0..j {
                    s -= l[i * d + k] * l[j * d + k];
                }
                l[i * d + j] = if i == j {
                    s.max(1e-300).sqrt()
                } else {
                    s / l[j * d + j]
                };
            }
        }
        let mut out = vec![0.0; d * no];
        for k in 0..no {
            let mut z = vec![0.0; d];
            for i in 0..d {
                let mut s = self.sxy[i * no + k];
                for j in 0..i {
                    s -= l[i * d + j] * z[j];
                }
                z[i] = s / l[i * d + i];
            }
            for i in (0..d).rev() {
                let mut s = z[i];
                for j in i + 1..d {
                    s -= l[j * d + i] * out[j * no + k];
                }
                out[i * no + k] = s / l[i * d + i];
            }
        }
        out
    }

    /// Applies the fit: `percept (B, n_in, h, w)` → `(B, n_out, h, w)`.
    pub fn apply(&self, percept: &[f32], batch: usize, h: usize, w: usize) -> Vec<f32> {
        let (ni, no) = (self.n_in, self.n_out);
        assert_eq!(
            percept.len(),
            batch * ni * h * w,
            "NeuralScope::apply: percept has {} values, want (B={batch}, {ni}, {h}, {w})",
            percept.len()
        );
        let a = self.weights();
        let hw = h * w;
        let mut out = vec![0.0f32; batch * no * hw];
        for b in 0..batch {
            for p in 0..hw {
                for k in 0..no {
                    let mut s = a[ni * no + k];
                    for c in 0..ni {
                        s += a[c * no + k] * percept[(b * ni + c) * hw + p] as f64;
                    }
                    out[(b * no + k) * hw + p] = s as f32;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_linear_map_exactly() {
        let (b, ni, no, h, w) = (2, 4, 3, 6, 6);
        let mut rng = crate::rng::CortexRng::seed_from(9);
        let truth: Vec<f64> = (0..(ni + 1) * no).map(|_| rng.normal()).collect();
        let percept: Vec<f32> = (0..b * ni * h * w).map(|_| rng.normal() as f32).collect();
        let mut scope = NeuralScope::new(ni, no, 0);
        scope.forgetting = 1.0;
        let target = {
            let hw = h * w;
            let mut t = vec![0.0f32; b * no * hw];
            for bb in 0..b {
                for p in 0..hw {
                    for k in 0..no {
                        let mut v = truth[ni * no + k];
                        for c in 0..ni {
                            v += truth[c * no + k] * percept[(bb * ni + c) * hw + p] as f64;
                        }
                        t[(bb * no + k) * hw + p] = v as f32;
                    }
                }
            }
            t
        };
        scope.update(&percept, &target, b, h, w);
        let got = scope.weights();
        for (g, t) in got.iter().zip(&truth) {
            assert!((g - t).abs() < 1e-3, "{g} vs {t}");
        }
        let pred = scope.apply(&percept, b, h, w);
        let err = pred
            .iter()
            .zip(&target)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(err < 1e-3);
    }

    #[test]
    fn no_data_gives_zero_map() {
        let s = NeuralScope::new(2, 3, 0);
        assert!(s.weights().iter().all(|&v| v == 0.0));
    }
}
