//! P (cone positions) against the truth: learned positions `P(uv)` and the true ones, both in
//! the normalised field [−1, 1]² on the same `n × n` lattice. Positions are identifiable only
//! up to an affine map, so the learned ones are first mapped onto the truth by least squares;
//! errors are then in local cone spacings (the mean distance from each true cone to its
//! lattice neighbours), and the spacing-map correlation compares nearest-neighbour distances.

use crate::stats;
use retina::Retina;
use serde::{Deserialize, Serialize};

/// How close the learned positions are to the true ones.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PRecovery {
    /// Correlation of the learned and true nearest-neighbour spacing maps.
    pub spacing_r: f64,
    /// RMS position error after the affine gauge, in local cone spacings.
    pub position_error_rms_cones: f64,
    /// Median position error after the affine gauge, in local cone spacings.
    pub position_error_median_cones: f64,
}

/// Mean distance from each lattice cell to its 4-neighbours, `(n²)`.
pub(super) fn local_spacing(points: &[[f64; 2]], n: usize) -> Vec<f64> {
    let d = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    let mut out = Vec::with_capacity(n * n);
    for y in 0..n {
        for x in 0..n {
            let here = points[y * n + x];
            let mut sum = 0.0;
            let mut count = 0;
            for (dy, dx) in [(0i64, 1i64), (0, -1), (1, 0), (-1, 0)] {
                let (yy, xx) = (y as i64 + dy, x as i64 + dx);
                if (0..n as i64).contains(&yy) && (0..n as i64).contains(&xx) {
                    sum += d(here, points[yy as usize * n + xx as usize]);
                    count += 1;
                }
            }
            out.push(sum / count as f64);
        }
    }
    out
}

/// Measures learned positions against the truth, both `(n², 2)` on the same `n × n` lattice.
pub fn measure_p(learned: &[[f64; 2]], truth: &[[f64; 2]], n: usize) -> PRecovery {
    assert!(
        learned.len() == n * n && truth.len() == n * n,
        "measure_p: {} learned and {} true positions for a {n}² lattice",
        learned.len(),
        truth.len()
    );
    let spacing = local_spacing(truth, n);
    let mapped = stats::fit_affine_2d(learned, truth);
    let mut errors: Vec<f64> = mapped
        .iter()
        .zip(truth)
        .zip(&spacing)
        .map(|((m, t), s)| ((m[0] - t[0]).powi(2) + (m[1] - t[1]).powi(2)).sqrt() / s)
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    errors.sort_by(f64::total_cmp);
    let spacing_r = stats::correlation(&local_spacing(learned, n), &spacing);
    PRecovery {
        spacing_r: if spacing_r.is_finite() {
            spacing_r
        } else {
            0.0
        },
        position_error_rms_cones: rms,
        position_error_median_cones: errors[errors.len() / 2],
    }
}

/// The true cone positions in the normalised field [−1, 1]², `(n²)` row-major.
pub fn true_positions(retina: &Retina) -> Vec<[f64; 2]> {
    retina
        .layout
        .positions_normalised()
        .iter()
        .map(|p| [p[0] as f64, p[1] as f64])
        .collect()
}
