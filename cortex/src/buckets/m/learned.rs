//! The learned motion estimator (paper S-03, "Learning Eye Motion Estimation"): what we built,
//! stated plainly.
//!
//! The paper learns M jointly with P by minimising the blurred prediction error
//! `‖B(O_{t+1}) − Ψ_P(Ω_M(Φ_P(B(O_t))))‖²`. The official code ships a non-learned pyramid search
//! instead (authors' code, docs/references.md#motion-estimation). Here:
//!
//! 1. **Coarse estimate**: the official block matching ([`super::block_matching`]) on blurred,
//!    P-de-warped ONS, an integer shift on the de-warped grid.
//! 2. **Sub-pixel refinement** (per sample, no gradient): Gauss–Newton on the blurred warp error
//!    itself, `E(d) = Σ_p mask·(B(O_{t+1})(p) − B(O_t)(P⁻¹(P(p) + d)))²` — exactly the paper's
//!    objective, evaluated through the current P with bilinear sampling. The Jacobian `∂/∂d` is
//!    taken by central differences of ± `refine_fd_step_px` de-warped pixels; each step is
//!    clamped to `refine_max_step_px`. Pixels are subsampled with `refine_stride_px`.
//! 3. **P learns on the same objective**: the trainer adds `blur_loss_weight · E(d̂)` (masked,
//!    official normalisation, through the tape) to the main loss, so P's parameters receive the
//!    gradient of the blurred objective as the paper describes.
//! 4. **Gauge**: because d̂ is measured through P, P's affine part (scale, shear, rotation,
//!    origin of the field) is invisible to both objectives; the trainer also adds
//!    `gauge_weight ×` the distance of P's affine fit from the identity
//!    ([`super::gauge`]). Without it P's scale drifted without bound under Adam and the
//!    estimate in field units with it (×300 by step ~280 on the quick LMS run, then a
//!    non-finite gradient).
//!
//! So M's "parameters" are per-sample (the refined d̂ is inferred, not amortised by a network),
//! and the learnable part optimised on the blurred objective is P. This keeps the estimator
//! small, exact at its optimum, and honest about what is learned.

use super::block_matching::DewarpGrid;
use super::sampling::{bilinear, unit_grid, unit_to_index};
use super::PlainFlow;
use rayon::prelude::*;

/// Gauss–Newton settings (from [`crate::config::MConfig`]).
#[derive(Clone, Debug)]
pub struct SubpixelRefiner {
    pub iterations: usize,
    pub fd_step_px: f64,
    pub max_step_px: f64,
    pub stride_px: usize,
    /// Pixels this close to an edge (of frame t+1, or of frame t at the sampled point) are left
    /// out: the loss border plus the blur's radius, where zero padding of the retina's filter
    /// and of the bilinear sampler would bias the estimate.
    pub margin_px: usize,
}

impl SubpixelRefiner {
    /// From the config.
    pub fn from_config(cfg: &crate::CortexConfig) -> Self {
        SubpixelRefiner {
            iterations: cfg.m.refine_iterations,
            fd_step_px: cfg.m.refine_fd_step_px,
            max_step_px: cfg.m.refine_max_step_px,
            stride_px: cfg.m.refine_stride_px.max(1),
            margin_px: cfg.loss.border_px + cfg.m.blur_kernel_px / 2,
        }
    }

    /// Refines `init` (field units, per sample) on blurred frames `b1`, `b2` `(B, n, n)`.
    /// `grid` gives the de-warped pixel steps used as the unknowns' units.
    #[allow(clippy::too_many_arguments)]
    pub fn refine(
        &self,
        b1: &[f32],
        b2: &[f32],
        n: usize,
        flow: &dyn PlainFlow,
        grid: &DewarpGrid,
        init: &[[f64; 2]],
    ) -> Vec<[f64; 2]> {
        let nn = n * n;
        let m = self.margin_px.min(n / 4);
        let (lo, hi) = (m, n - m);
        let (inner_lo, inner_hi) = (m as f64, (n - 1 - m) as f64);
        let inside = move |q: [f64; 2]| {
            let (x, y) = (unit_to_index(q[0], n), unit_to_index(q[1], n));
            x >= inner_lo && x <= inner_hi && y >= inner_lo && y <= inner_hi
        };
        let pix: Vec<usize> = (lo..hi)
            .step_by(self.stride_px)
            .flat_map(|y| (lo..hi).step_by(self.stride_px).map(move |x| y * n + x))
            .collect();
        let all = unit_grid(n);
        let mut xy: Vec<[f64; 2]> = pix.iter().map(|&p| all[p]).collect();
        flow.forward(&mut xy);
        let [ex, ey] = grid.xy_step;
        let at = |d: [f64; 2], s: [f64; 2]| {
            [
                d[0] + s[0] * ex[0] + s[1] * ey[0],
                d[1] + s[0] * ex[1] + s[1] * ey[1],
            ]
        };
        init.par_iter()
            .enumerate()
            .map(|(b, &d0)| {
                let (f1, f2) = (&b1[b * nn..(b + 1) * nn], &b2[b * nn..(b + 1) * nn]);
                let mut pts = vec![[0.0; 2]; xy.len()];
                let sample = |d: [f64; 2],
                              pts: &mut Vec<[f64; 2]>,
                              out: &mut Vec<f64>,
                              mask: Option<&mut Vec<bool>>| {
                    for (q, p) in pts.iter_mut().zip(&xy) {
                        *q = [p[0] + d[0], p[1] + d[1]];
                    }
                    flow.inverse(pts);
                    out.clear();
                    out.extend(pts.iter().map(|&q| bilinear(f1, n, n, q)));
                    if let Some(m) = mask {
                        m.clear();
                        m.extend(pts.iter().map(|&q| inside(q)));
                    }
                };
                let mut d = d0;
                let (mut v0, mut vp, mut vm) = (Vec::new(), Vec::new(), Vec::new());
                let mut jac = [Vec::new(), Vec::new()];
                let mut mask = Vec::new();
                let h = self.fd_step_px;
                for _ in 0..self.iterations {
                    sample(d, &mut pts, &mut v0, Some(&mut mask));
                    for (k, j) in jac.iter_mut().enumerate() {
                        let mut s = [0.0; 2];
                        s[k] = h;
                        sample(at(d, s), &mut pts, &mut vp, None);
                        s[k] = -h;
                        sample(at(d, s), &mut pts, &mut vm, None);
                        j.clear();
                        j.extend(vp.iter().zip(&vm).map(|(a, b)| (a - b) / (2.0 * h)));
                    }
                    let (mut a00, mut a01, mut a11, mut g0, mut g1) = (0.0, 0.0, 0.0, 0.0, 0.0);
                    for (i, &p) in pix.iter().enumerate() {
                        if !mask[i] {
                            continue;
                        }
                        let r = f2[p] as f64 - v0[i];
                        let (j0, j1) = (jac[0][i], jac[1][i]);
                        a00 += j0 * j0;
                        a01 += j0 * j1;
                        a11 += j1 * j1;
                        g0 += j0 * r;
                        g1 += j1 * r;
                    }
                    let det = a00 * a11 - a01 * a01;
                    let floor = 1e-12 * (a00 * a11).max(1e-300);
                    if det.is_nan() || det <= floor {
                        break;
                    }
                    let mut s = [(a11 * g0 - a01 * g1) / det, (a00 * g1 - a01 * g0) / det];
                    let len = (s[0] * s[0] + s[1] * s[1]).sqrt();
                    if len > self.max_step_px {
                        s = [s[0] * self.max_step_px / len, s[1] * self.max_step_px / len];
                    }
                    d = at(d, s);
                    if len < 1e-4 {
                        break;
                    }
                }
                d
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::buckets::m::block_matching::DewarpGrid;
    use crate::buckets::m::IdentityFlow;

    /// A smooth image shifted by a known sub-pixel amount: the refinement finds it.
    #[test]
    fn refinement_recovers_a_subpixel_shift() {
        let n = 48;
        let f = |x: f64, y: f64| {
            (0.21 * x).sin() + (0.17 * y + 0.3).cos() + 0.5 * (0.11 * (x + y)).sin()
        };
        let s = [2.35, -1.6]; // px
        let mut b1 = vec![0.0f32; n * n];
        let mut b2 = vec![0.0f32; n * n];
        for y in 0..n {
            for x in 0..n {
                b1[y * n + x] = f(x as f64, y as f64) as f32;
                b2[y * n + x] = f(x as f64 + s[0], y as f64 + s[1]) as f32;
            }
        }
        let grid = DewarpGrid::new(&IdentityFlow, n, 64);
        let cfg = crate::CortexConfig::tiny();
        let mut r = SubpixelRefiner::from_config(&cfg);
        r.iterations = 5;
        let unit = 2.0 / (n as f64 - 1.0);
        let init = [[2.0 * unit, -2.0 * unit]];
        let got = r.refine(&b1, &b2, n, &IdentityFlow, &grid, &init)[0];
        let err = ((got[0] / unit - s[0]).powi(2) + (got[1] / unit - s[1]).powi(2)).sqrt();
        // bilinear sampling of a smooth image: sub-pixel accurate to a few hundredths of a pixel
        assert!(
            err < 0.05,
            "refined {:?} px, true {s:?}",
            [got[0] / unit, got[1] / unit]
        );
    }
}
