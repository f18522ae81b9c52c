//! A control for a fourth cone class: scenes whose Q plane is replaced by its fixed affine
//! least-squares prediction from the L, M and S planes, so Q carries nothing of its own.
//!
//! With `[retina.scenes] q_from_lms = "before_balance"` or `"after_balance"` a scene pool fits
//! once, on [`Q_FIT_TILES`] tiles drawn from their own seed ([`Q_FIT_SEED`]), the coefficients
//! `c` of `Q ≈ c₀ + c_L·L + c_M·M + c_S·S` (over every [`Q_FIT_STRIDE_PX`]-th pixel per axis of
//! those tiles, at the stage named), then sets every tile's Q plane to that prediction:
//! - `before_balance`: on the projected planes before the per-image white balance (the balance
//!   then divides each plane by its own maximum, so within one tile Q stays an affine function
//!   of L, M, S, with coefficients that vary from tile to tile);
//! - `after_balance`: on the balanced planes, so Q is the same affine function of L, M, S in
//!   every tile.
//!
//! The eye keeps its Q cones and their sensitivity: only what the scenes put on the Q plane
//! changes (spectral test lights still excite Q on its own). Unset (the default), nothing is
//! replaced and a pool draws exactly the tiles it drew before this setting existed. Planes are
//! `(n_planes, h, w)` as in [`ClassPlanes`]; L, M, S are the reference planes, Q the plane of
//! the mosaic class named `Q`.

use serde::{Deserialize, Serialize};

use super::ClassPlanes;
use colorimetry::linalg::{lstsq, DEFAULT_RCOND};

/// Tiles the coefficients are fitted on.
pub const Q_FIT_TILES: usize = 16;
/// Seed of the fitting tiles' draws (fixed, so every run of a setting replaces Q with the same
/// coefficients; the pool's own draws are untouched).
pub const Q_FIT_SEED: u64 = 0x5157_4c4d_5346_4954;
/// Every this many pixels per axis of a fitting tile enters the fit, px.
pub const Q_FIT_STRIDE_PX: usize = 4;

/// Where in a scene's preparation the Q plane is replaced (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QFromLms {
    /// On the projected planes, before the white balance.
    BeforeBalance,
    /// On the white-balanced planes.
    AfterBalance,
}

/// The fitted replacement: which planes, and `Q = c₀ + c_L·L + c_M·M + c_S·S`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QFromLmsFit {
    /// The stage it applies at.
    pub stage: QFromLms,
    /// Plane index of Q.
    pub q_plane: usize,
    /// Plane indices of L, M, S.
    pub lms_planes: [usize; 3],
    /// `[c₀, c_L, c_M, c_S]`.
    pub coefficients: [f64; 4],
}

impl QFromLmsFit {
    /// The affine least-squares fit of plane `q_plane` from `lms_planes` over every
    /// [`Q_FIT_STRIDE_PX`]-th pixel per axis of `tiles`.
    pub fn fit(
        stage: QFromLms,
        tiles: &[ClassPlanes],
        q_plane: usize,
        lms_planes: [usize; 3],
    ) -> QFromLmsFit {
        let (mut design, mut target) = (Vec::new(), Vec::new());
        for t in tiles {
            let (q, lms) = (t.plane(q_plane), lms_planes.map(|p| t.plane(p)));
            for y in (0..t.h).step_by(Q_FIT_STRIDE_PX) {
                for x in (0..t.w).step_by(Q_FIT_STRIDE_PX) {
                    let i = y * t.w + x;
                    design.push(1.0);
                    design.extend(lms.iter().map(|p| p[i] as f64));
                    target.push(q[i] as f64);
                }
            }
        }
        let beta = lstsq(&design, target.len(), 4, &target, 1, DEFAULT_RCOND).x;
        QFromLmsFit {
            stage,
            q_plane,
            lms_planes,
            coefficients: [beta[0], beta[1], beta[2], beta[3]],
        }
    }

    /// The prediction at one place.
    pub fn predict(&self, lms: [f32; 3]) -> f32 {
        let c = &self.coefficients;
        (c[0] + c[1] * lms[0] as f64 + c[2] * lms[1] as f64 + c[3] * lms[2] as f64) as f32
    }

    /// Sets the Q plane of `planes` to the prediction from its L, M, S planes.
    pub fn replace(&self, planes: &mut ClassPlanes) {
        let hw = planes.h * planes.w;
        let lms: Vec<Vec<f32>> = self
            .lms_planes
            .iter()
            .map(|&p| planes.plane(p).to_vec())
            .collect();
        let q = &mut planes.planes[self.q_plane * hw..(self.q_plane + 1) * hw];
        for (i, v) in q.iter_mut().enumerate() {
            *v = self.predict([lms[0][i], lms[1][i], lms[2][i]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn planes(h: usize, w: usize, q: impl Fn(f32, f32, f32) -> f32) -> ClassPlanes {
        let hw = h * w;
        let mut data = vec![0.0f32; 4 * hw];
        for i in 0..hw {
            let (l, m, s) = (
                (i as f32 * 0.37).sin().abs(),
                (i as f32 * 0.11).cos().abs(),
                ((i * i) as f32 * 0.013).sin().abs(),
            );
            data[i] = l;
            data[hw + i] = m;
            data[2 * hw + i] = s;
            data[3 * hw + i] = q(l, m, s);
        }
        ClassPlanes {
            h,
            w,
            k: 4,
            n_planes: 4,
            planes: data,
            reference_lms: [0, 1, 2],
        }
    }

    #[test]
    fn an_affine_q_is_recovered_exactly() {
        let tile = planes(24, 20, |l, m, s| 0.1 + 0.5 * l - 0.25 * m + 2.0 * s);
        let fit = QFromLmsFit::fit(QFromLms::AfterBalance, &[tile], 3, [0, 1, 2]);
        for (got, want) in fit.coefficients.iter().zip([0.1, 0.5, -0.25, 2.0]) {
            assert!((got - want).abs() < 1e-5, "{:?}", fit.coefficients);
        }
    }

    #[test]
    fn the_replaced_plane_equals_the_fit_and_only_q_changes() {
        let tile = planes(16, 16, |l, m, s| (3.0 * l * m).sin() + s * s);
        let fit = QFromLmsFit::fit(
            QFromLms::BeforeBalance,
            std::slice::from_ref(&tile),
            3,
            [0, 1, 2],
        );
        let mut replaced = tile.clone();
        fit.replace(&mut replaced);
        let hw = 16 * 16;
        assert_eq!(replaced.planes[..3 * hw], tile.planes[..3 * hw]);
        let c = fit.coefficients;
        for i in 0..hw {
            let (l, m, s) = (tile.planes[i], tile.planes[hw + i], tile.planes[2 * hw + i]);
            let want = c[0] + c[1] * l as f64 + c[2] * m as f64 + c[3] * s as f64;
            assert!((replaced.planes[3 * hw + i] as f64 - want).abs() < 1e-5);
        }
        // A nonlinear Q is not its own affine prediction: the replacement changed it.
        assert_ne!(replaced.planes[3 * hw..], tile.planes[3 * hw..]);
    }
}
