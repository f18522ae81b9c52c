//! The gauge of the learned motion estimator: why P's affine part must be pinned when M is
//! estimated through P, and the term that pins it.
//!
//! **The symmetry.** The warp predicts frame t+1 at ONS point uv from frame t at
//! `uv' = P⁻¹(P(uv) + d)`. For any invertible 2×2 `A` and any `c`, the map `P̃ = A·P + c` with
//! motion `d̃ = A·d` gives `P̃⁻¹(P̃(uv) + d̃) = P⁻¹(P(uv) + d)`: the same prediction. With the
//! oracle, `d` is fixed in the retina's units and the symmetry is broken. With an estimated
//! `d` it is not: M measures `d` on the grid de-warped through the current P and converts it
//! with P's own xy steps, so `d̂` follows every affine change of P. Nothing in the loss fixes
//! P's affine part (6 degrees of freedom: scale, shear and rotation of the field, and its
//! origin).
//!
//! **Why it diverges rather than merely wanders.** The loss gradient along the symmetry, with
//! `d̂` held fixed, is `−∂L/∂d · (δA·d̂)`: zero only where `d̂` minimises the main loss. It
//! does not: `d̂` minimises the *blurred* objective, from an integer start, in a few
//! Gauss–Newton steps. That small systematic gradient is what Adam normalises into a
//! full-size step, every step, in the same direction, and the steps compound through the
//! flow's `exp` log-scales. Measured on the quick LMS run without this term: P's affine fit
//! grew from the identity to ×1.3 by step 30, ×10 by ~150 and ×300 by ~280 (the estimate in
//! field units following it, 709 "px" against true shifts ≤ 15 px), until the exponentials
//! overflowed (non-finite gradient of `p.block0.fc1.weight`).
//!
//! **The gauge term.** Fix the representative: the least-squares affine fit of `xy = P(uv)`
//! over the ONS grid, `xy ≈ A·uv + c`, must be the identity (`A = I`, `c = 0`), the layout P
//! starts from. The loss gets `gauge_weight · S · (‖A − I‖²_F + ‖c‖²)` with `S` the number of
//! sites the main loss sums over (authors' code, docs/references.md#loss normalisation), so that the pull is measured
//! in the loss's own units whatever n. Any P has a
//! gauge-equivalent P̃ with this term zero and the same predictions, so the term changes
//! which P represents the solution, not which predictions are reachable; the non-affine part
//! of P (what P is for: the cells' irregular positions) is untouched.
//!
//! Fit: with `U = [u_x, u_y, 1]` per grid point (`N×3`) and `G = U (UᵀU)⁻¹`, the fit is
//! `F = Gᵀ·xy` (`3×2`): row 0 is `∂xy/∂u_x` (`[A₀₀, A₁₀]`), row 1 `∂xy/∂u_y`, row 2 `c`.

use super::sampling::unit_grid;
use super::PlainFlow;
use autodiff::{Tape, Var};

/// The least-squares fit `xy ≈ A·uv + c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AffineFit {
    /// `a[i][j] = ∂xy_i/∂uv_j`.
    pub a: [[f64; 2]; 2],
    pub c: [f64; 2],
}

impl AffineFit {
    /// `‖A − I‖²_F + ‖c‖²`, the gauge term without its weight.
    pub fn deviation_sq(&self) -> f64 {
        let [[a00, a01], [a10, a11]] = self.a;
        (a00 - 1.0).powi(2)
            + a01 * a01
            + a10 * a10
            + (a11 - 1.0).powi(2)
            + self.c[0].powi(2)
            + self.c[1].powi(2)
    }
}

/// `Gᵀ = (UᵀU)⁻¹ Uᵀ` for `U = [u_x, u_y, 1]`, as a `3×N` row-major matrix.
pub fn fit_operator(uv: &[[f64; 2]]) -> Vec<f64> {
    let n = uv.len();
    let mut m = [[0.0f64; 3]; 3];
    for p in uv {
        let u = [p[0], p[1], 1.0];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += u[i] * u[j];
            }
        }
    }
    let inv = invert3(m).unwrap_or_else(|| {
        panic!("gauge::fit_operator: the {n} points do not span the plane (UᵀU is singular)")
    });
    let mut g = vec![0.0; 3 * n];
    for (k, p) in uv.iter().enumerate() {
        let u = [p[0], p[1], 1.0];
        for i in 0..3 {
            g[i * n + k] = (0..3).map(|j| inv[i][j] * u[j]).sum();
        }
    }
    g
}

fn invert3(m: [[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
    };
    let det = m[0][0] * cof(0, 0) + m[0][1] * cof(0, 1) + m[0][2] * cof(0, 2);
    let scale = m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    if !det.is_finite() || det.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    // inverse = adjugate / det; adjugate[i][j] = cofactor[j][i]
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = cof(j, i) / det;
        }
    }
    Some(inv)
}

/// The affine fit of `xy` (the images of `uv`, same length).
pub fn affine_fit(uv: &[[f64; 2]], xy: &[[f64; 2]]) -> AffineFit {
    assert_eq!(
        uv.len(),
        xy.len(),
        "gauge::affine_fit: {} uv points vs {} xy points",
        uv.len(),
        xy.len()
    );
    let g = fit_operator(uv);
    let n = uv.len();
    let mut f = [[0.0f64; 2]; 3];
    for (i, row) in f.iter_mut().enumerate() {
        for (k, p) in xy.iter().enumerate() {
            row[0] += g[i * n + k] * p[0];
            row[1] += g[i * n + k] * p[1];
        }
    }
    AffineFit {
        a: [[f[0][0], f[1][0]], [f[0][1], f[1][1]]],
        c: f[2],
    }
}

/// The affine fit of P over the `n×n` ONS grid.
pub fn flow_affine_fit(flow: &dyn PlainFlow, n: usize) -> AffineFit {
    let uv = unit_grid(n);
    let mut xy = uv.clone();
    flow.forward(&mut xy);
    affine_fit(&uv, &xy)
}

/// Records `‖F − [I; 0]‖²` (rank 0) for `xy` `(N, 2)` on the tape, the images of the
/// constant points `uv` (N of them). Multiply by the gauge weight at the call site.
pub fn record_gauge_term(tape: &mut Tape<f32>, xy: Var, uv: &[[f64; 2]]) -> Var {
    let n = uv.len();
    let s = tape.shape(xy);
    assert!(
        s.rank() == 2 && s.dim(0) == n && s.dim(1) == 2,
        "gauge::record_gauge_term: xy {s:?} vs {n} uv points"
    );
    let g: Vec<f32> = fit_operator(uv).into_iter().map(|v| v as f32).collect();
    let g = tape.constant_from([3, n], &g);
    let fit = tape.matmul(g, xy);
    let target = tape.constant_from([3, 2], &[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    // mse divides by the 6 entries
    let e = tape.mse(fit, target);
    tape.scale(e, 6.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::buckets::m::IdentityFlow;

    struct Affine(AffineFit);

    impl PlainFlow for Affine {
        fn forward(&self, pts: &mut [[f64; 2]]) {
            let AffineFit { a, c } = self.0;
            for p in pts {
                *p = [
                    a[0][0] * p[0] + a[0][1] * p[1] + c[0],
                    a[1][0] * p[0] + a[1][1] * p[1] + c[1],
                ];
            }
        }
        fn inverse(&self, _pts: &mut [[f64; 2]]) {
            unreachable!("the fit only maps forward")
        }
    }

    /// An affine P is fitted exactly; a non-affine bump on top of the identity that is odd in
    /// neither axis' fit leaves the fit at the identity; the identity has zero deviation.
    #[test]
    fn fit_recovers_affine_maps_and_ignores_the_non_affine_part() {
        let want = AffineFit {
            a: [[1.7, -0.3], [0.2, 0.6]],
            c: [0.4, -1.1],
        };
        let got = flow_affine_fit(&Affine(want), 16);
        for (g, w) in [got.a[0], got.a[1], got.c]
            .iter()
            .flatten()
            .zip([want.a[0], want.a[1], want.c].iter().flatten())
        {
            assert!((g - w).abs() < 1e-12, "{got:?} vs {want:?}");
        }
        let id = flow_affine_fit(&IdentityFlow, 16);
        assert!(id.deviation_sq() < 1e-24, "{id:?}");
        // xy = uv + 0.1·(u_x² − mean, u_y² − mean): even, so orthogonal to 1, u_x, u_y on the
        // symmetric grid after removing its mean
        let uv = unit_grid(16);
        let m = uv.iter().map(|p| p[0] * p[0]).sum::<f64>() / uv.len() as f64;
        let xy: Vec<[f64; 2]> = uv
            .iter()
            .map(|p| {
                [
                    p[0] + 0.1 * (p[0] * p[0] - m),
                    p[1] + 0.1 * (p[1] * p[1] - m),
                ]
            })
            .collect();
        assert!(affine_fit(&uv, &xy).deviation_sq() < 1e-24);
    }

    /// The tape term equals the plain deviation, and its gradient with respect to xy matches
    /// central differences of the plain deviation (f64 reference).
    #[test]
    fn tape_term_matches_plain_deviation_and_its_gradient() {
        let uv = unit_grid(6);
        let mut rng = crate::rng::CortexRng::seed_from(3);
        let xy: Vec<[f64; 2]> = uv
            .iter()
            .map(|p| {
                [
                    1.3 * p[0] - 0.2 * p[1] + 0.1 + 0.05 * rng.normal(),
                    0.1 * p[0] + 0.8 * p[1] - 0.3 + 0.05 * rng.normal(),
                ]
            })
            .collect();
        let mut tape = Tape::<f32>::new();
        let flat: Vec<f32> = xy.iter().flatten().map(|&v| v as f32).collect();
        let x = tape.leaf(autodiff::Tensor::from_vec([uv.len(), 2], flat));
        let term = record_gauge_term(&mut tape, x, &uv);
        let got = tape.value(term).item() as f64;
        let want = affine_fit(&uv, &xy).deviation_sq();
        assert!((got - want).abs() < 1e-5 * want, "{got} vs {want}");
        assert!(want > 0.1, "the test map must be far from the identity");
        tape.backward(term);
        let grad = tape.grad(x).expect("xy gets a gradient").data().to_vec();
        let h = 1e-6;
        for k in [0, 1, 17, 40, 71] {
            let (i, j) = (k / 2, k % 2);
            let mut plus = xy.clone();
            plus[i][j] += h;
            let mut minus = xy.clone();
            minus[i][j] -= h;
            let fd = (affine_fit(&uv, &plus).deviation_sq()
                - affine_fit(&uv, &minus).deviation_sq())
                / (2.0 * h);
            assert!(
                (grad[k] as f64 - fd).abs() < 1e-4 * (1.0 + fd.abs()),
                "entry {k}: tape {} vs central difference {fd}",
                grad[k]
            );
        }
    }
}

#[cfg(test)]
mod training_tests {
    use super::*;
    use crate::config::{CortexConfig, MMode};
    use crate::synthetic::{SyntheticConfig, SyntheticSource};
    use crate::Trainer;

    /// The largest `‖A − I‖²_F + ‖c‖²` of P's affine fit over `steps` steps of learned-M
    /// training with `gauge_weight`.
    fn worst_drift(gauge_weight: f64, steps: u64) -> f64 {
        worst_drift_with(MMode::Learned, gauge_weight, steps)
    }

    /// [`worst_drift`] for any estimated-motion mode.
    fn worst_drift_with(mode: MMode, gauge_weight: f64, steps: u64) -> f64 {
        let mut cfg = CortexConfig::tiny();
        cfg.m.mode = mode;
        cfg.m.gauge_weight = gauge_weight;
        let n = cfg.ons_size_px;
        let mut t = Trainer::new(cfg).unwrap();
        let mut src = SyntheticSource::new(SyntheticConfig {
            max_shift_px: 7,
            ..SyntheticConfig::lms(n, 5)
        });
        let mut worst = 0.0f64;
        t.run(&mut src, steps, None, |_, t| {
            let fit = flow_affine_fit(t.cortex.p.plain(&t.cortex.params).as_ref(), n);
            worst = worst.max(fit.deviation_sq());
        })
        .unwrap();
        println!("{mode:?}, gauge_weight {gauge_weight}: worst deviation² {worst:.2e}");
        worst
    }

    /// With the learned M, P's affine part is free (module docs): without the gauge term it
    /// drifts steadily (on the quick LMS run this compounded to ×300 and a non-finite
    /// gradient); with the default term it stays within 3 % of the identity.
    #[test]
    fn gauge_term_keeps_p_affine_part_at_identity_under_learned_motion() {
        let steps = 30;
        let free = worst_drift(0.0, steps);
        let pinned = worst_drift(CortexConfig::tiny().m.gauge_weight, steps);
        assert!(free > 1e-2, "without the term P should drift: {free:.2e}");
        assert!(pinned < 1e-3, "with the term P drifted: {pinned:.2e}");
    }

    /// Block matching also measures the motion through P, so it leaves the same freedom:
    /// measured 2.1e-2 without the term and 2.0e-4 with it over 30 tiny steps.
    #[test]
    fn gauge_term_keeps_p_affine_part_at_identity_under_block_matching() {
        let free = worst_drift_with(MMode::BlockMatching, 0.0, 30);
        let pinned = worst_drift_with(
            MMode::BlockMatching,
            CortexConfig::tiny().m.gauge_weight,
            30,
        );
        assert!(free > 1e-2, "without the term P should drift: {free:.2e}");
        assert!(pinned < 1e-3, "with the term P drifted: {pinned:.2e}");
    }
}
