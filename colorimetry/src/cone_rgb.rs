//! Linear sRGB ↔ cone excitations through CIE XYZ (authors' code, docs/references.md#colour-transforms).
//!
//! 1. XYZ → cones (3×K): least-squares fit of the fundamentals `F` (grid × K) from the CIE 1931
//!    CMFs `X̄` (grid × 3) on the fundamentals' grid: `A = argmin ‖X̄·A − F‖`. The fit is only
//!    approximate (official: 9 / 19 / 20 % relative residual for L / M / S); the residuals are
//!    kept in [`ConeRgb::fit_residual_rel`].
//! 2. linear sRGB → cones = `Mᵀ·A` with `M` the sRGB → XYZ matrix (white Y = 1): for a row
//!    vector `rgb`, `cones = rgb · (Mᵀ·A)`. Stored row-major (3 × K), rows R, G, B.
//! 3. cones → linear sRGB: the inverse of that 3×3 block for K = 3; for K ≠ 3 the minimum-norm
//!    least-squares inverse (the official code returns the cone values unchanged for K = 4;
//!    we prefer a map that is at least a right inverse on the RGB-reachable subspace).
//!
//! Units: cone excitations are `Σ_λ spectrum(λ)·F(λ)` in the official pre-integration scale
//! (plain sums over the grid, XYZ likewise), so the sRGB white (1, 1, 1) gives L ≈ 1.08 on the
//! official 1 nm grid.

use crate::cie::CieObserver;
use crate::cones::ConeFundamentals;
use crate::error::Result;
use crate::linalg::{lstsq, DEFAULT_RCOND};
use crate::srgb::linear_srgb_to_xyz_matrix;

/// Linear sRGB ↔ cone-excitation matrices for one set of fundamentals.
#[derive(Debug, Clone, PartialEq)]
pub struct ConeRgb {
    /// Number of cone classes K.
    pub n_classes: usize,
    /// XYZ → cones, row-major (3 × K): `cones = xyz · A`.
    pub xyz_to_cone: Vec<f64>,
    /// linear sRGB → cones, row-major (3 × K), rows R, G, B.
    pub rgb_to_cone: Vec<f64>,
    /// cones → linear sRGB, row-major (K × 3).
    pub cone_to_rgb: Vec<f64>,
    /// Relative residual `‖X̄·a_c − f_c‖ / ‖f_c‖` of each class's fit.
    pub fit_residual_rel: Vec<f64>,
}

impl ConeRgb {
    /// Fit the matrices for `fundamentals` (their grid must lie within 360–830 nm).
    pub fn fit(fundamentals: &ConeFundamentals) -> Result<Self> {
        let grid = &fundamentals.grid;
        let obs = CieObserver::cie1931(grid)?;
        let n = grid.len();
        let k = fundamentals.n_classes();
        // CIE table has ȳ peak 1 at 555 nm, as the official CIEXYZ.cpkl; plain sums.
        let xbar = obs.cmf_matrix();
        let sol = lstsq(&xbar, n, 3, &fundamentals.values, k, DEFAULT_RCOND);
        let a = sol.x; // 3 × K
        let mut fit_residual_rel = vec![0.0; k];
        for (c, r) in fit_residual_rel.iter_mut().enumerate() {
            let (mut num, mut den) = (0.0, 0.0);
            for w in 0..n {
                let pred: f64 = (0..3).map(|j| xbar[w * 3 + j] * a[j * k + c]).sum();
                let f = fundamentals.get(w, c);
                num += (pred - f).powi(2);
                den += f * f;
            }
            *r = (num / den).sqrt();
        }
        let m = linear_srgb_to_xyz_matrix();
        // rgb_to_cone[r][c] = Σ_j M[j][r] · A[j][c]
        let mut rgb_to_cone = vec![0.0; 3 * k];
        for r in 0..3 {
            for c in 0..k {
                rgb_to_cone[r * k + c] = (0..3).map(|j| m[j][r] * a[j * k + c]).sum();
            }
        }
        // cones → rgb: solve rgb · B = cones for rgb in least squares: Bᵀ · rgbᵀ = conesᵀ,
        // i.e. the (K × 3) matrix C with rgb = cones · C is pinv(B).
        let mut bt = vec![0.0; k * 3];
        for r in 0..3 {
            for c in 0..k {
                bt[c * 3 + r] = rgb_to_cone[r * k + c];
            }
        }
        let mut eye = vec![0.0; k * k];
        for i in 0..k {
            eye[i * k + i] = 1.0;
        }
        // X (3 × K) = pinv(Bᵀ) so that rgbᵀ = X · conesᵀ; C = Xᵀ (K × 3).
        let x = lstsq(&bt, k, 3, &eye, k, DEFAULT_RCOND).x;
        let mut cone_to_rgb = vec![0.0; k * 3];
        for r in 0..3 {
            for c in 0..k {
                cone_to_rgb[c * 3 + r] = x[r * k + c];
            }
        }
        Ok(ConeRgb {
            n_classes: k,
            xyz_to_cone: a,
            rgb_to_cone,
            cone_to_rgb,
            fit_residual_rel,
        })
    }

    /// Cone excitations of a linear sRGB colour, written into `out` (length K).
    pub fn rgb_to_cones_into(&self, rgb: [f64; 3], out: &mut [f64]) {
        let k = self.n_classes;
        assert_eq!(
            out.len(),
            k,
            "ConeRgb::rgb_to_cones_into: out {} vs K {k}",
            out.len()
        );
        for (c, o) in out.iter_mut().enumerate() {
            *o = (0..3).map(|r| rgb[r] * self.rgb_to_cone[r * k + c]).sum();
        }
    }

    /// Cone excitations of a linear sRGB colour.
    pub fn rgb_to_cones(&self, rgb: [f64; 3]) -> Vec<f64> {
        let mut out = vec![0.0; self.n_classes];
        self.rgb_to_cones_into(rgb, &mut out);
        out
    }

    /// Linear sRGB of cone excitations (length K).
    pub fn cones_to_rgb(&self, cones: &[f64]) -> [f64; 3] {
        assert_eq!(cones.len(), self.n_classes, "ConeRgb::cones_to_rgb: length");
        let mut rgb = [0.0; 3];
        for (c, &v) in cones.iter().enumerate() {
            for (r, o) in rgb.iter_mut().enumerate() {
                *o += v * self.cone_to_rgb[c * 3 + r];
            }
        }
        rgb
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cones::{sensitivities, ConeClass, ConeTemplate};
    use crate::grid::WavelengthGrid;

    #[test]
    fn official_lms_matrices_are_reproduced() {
        let f = sensitivities(
            &ConeClass::lms(),
            &ConeTemplate::default(),
            &WavelengthGrid::official_1nm(),
        )
        .unwrap();
        let m = ConeRgb::fit(&f).unwrap();
        // authors' code, docs/references.md#colour-transforms, 3 decimals; tolerance = rounding (5e-4) + 5e-4 for the official
        // cubic-spline vs our linear lens resampling between whole nm
        let want = [
            [0.247, 0.046, 0.018],
            [0.714, 0.748, 0.036],
            [0.122, 0.212, 0.466],
        ];
        for r in 0..3 {
            for c in 0..3 {
                let got = m.rgb_to_cone[r * 3 + c];
                assert!((got - want[r][c]).abs() < 1e-3, "row {r} col {c}: {got}");
            }
        }
        let col0 = [m.cone_to_rgb[0], m.cone_to_rgb[3], m.cone_to_rgb[6]];
        for (g, w) in col0.iter().zip([4.849, -4.665, 0.848]) {
            assert!((g - w).abs() < 1e-3, "LMS→R {col0:?}");
        }
        for (g, w) in m.fit_residual_rel.iter().zip([0.09, 0.19, 0.20]) {
            // official quotes whole percent
            assert!((g - w).abs() <= 0.005, "residuals {:?}", m.fit_residual_rel);
        }
        eprintln!(
            "rgb→LMS {:?}\nLMS→R {col0:?}\nresiduals {:?}",
            m.rgb_to_cone, m.fit_residual_rel
        );
    }

    #[test]
    fn round_trip_for_three_and_four_classes() {
        let g = WavelengthGrid::default();
        let f = sensitivities(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
        let m = ConeRgb::fit(&f).unwrap();
        let rgb = [0.3, 0.6, 0.1];
        let back = m.cones_to_rgb(&m.rgb_to_cones(rgb));
        assert!(rgb.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-10));
        let mut four = ConeClass::lms();
        four.push(ConeClass::pigeon_q());
        let f4 = sensitivities(&four, &ConeTemplate::default(), &g).unwrap();
        let m4 = ConeRgb::fit(&f4).unwrap();
        let back = m4.cones_to_rgb(&m4.rgb_to_cones(rgb));
        assert!(rgb.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-10));
    }
}
