//! The oracle's demosaicker for cones that mix opsins at many ratios — gene therapy "mixed at
//! random" (paper S-06: every affected cone expresses r·L + (1−r)·M with its own r), where the
//! cones fall in too many kinds to interpolate kind by kind.
//!
//! - **Blocks.** Opsin classes that share a cone form a block (the union over every weight row):
//!   {L, M} and {S} for `MS+L_ratio_M`; each pure class on its own in an unmodified mosaic.
//! - **Row space.** A block's cones see its excitations `e` through their weight rows,
//!   `a_i = w_i · e`. The rows span a subspace of rank r (2 for L and M mixed at random, 1 for
//!   a pure class) with orthonormal basis `U` (eigenvectors of `Σ_i w_i w_iᵀ` above
//!   [`ROW_SPACE_CUTOFF`] of the largest; each signed so its largest entry is positive); a cone's
//!   coordinates are `u_i = Uᵀ w_i`.
//! - **Weighted least squares.** At every cell j the decoder solves
//!   `min_f Σ_i g_ij (a_i − u_i · f)²` over the block's cones, `g_ij` the oracle's Gaussian
//!   (σ = [`INTERPOLATION_SIGMA_SPACINGS`] × the mean neighbour spacing of the block's cones,
//!   truncated at [`super::oracle::INTERPOLATION_REACH_SIGMAS`] σ), widened by [`WIDENING`]
//!   until the normal matrix `Σ g u uᵀ` has conditioning ≥ [`MIN_CONDITIONING`]. Inside any
//!   uniform region wider than the kernel it returns `f = Uᵀ e` exactly: an ideal demosaicker.
//!
//! The planes are `r` per block, `Σ r` the rank of the mosaic's weight rows (3 for the mixed
//! gene-therapy eye). For a pure class (`r = 1`, `u_i = 1`) the solve is the normalised
//! Gaussian mean of the kind-by-kind oracle, tap for tap (a test pins it).

use super::oracle::{gaussian_neighbours, mean_spacing_px, nearest, INTERPOLATION_SIGMA_SPACINGS};
use colorimetry::linalg::{signed_eigenvector, symmetric_eigen};
use retina::Retina;

/// Eigenvalues of a block's `Σ w wᵀ` below this fraction of the largest count as zero.
pub const ROW_SPACE_CUTOFF: f64 = 1e-9;
/// Smallest ratio of the smallest to the largest eigenvalue of a cell's normal matrix.
pub const MIN_CONDITIONING: f64 = 1e-3;
/// Factor σ grows by while a cell's normal matrix is worse conditioned.
pub const WIDENING: f64 = 1.5;
/// Widenings before the cell falls back to the pseudo-inverse.
const MAX_WIDENINGS: usize = 12;
/// Weights at or below this count as "the cone does not express the opsin".
const EXPRESSED: f32 = 1e-6;

/// Per plane and cell (plane-major, `planes × n²`), the taps `(cell, weight)` whose sum over a
/// frame's activations is that plane's value at the cell; and the number of planes.
pub(super) fn least_squares_taps(retina: &Retina) -> (Vec<Vec<(u32, f32)>>, usize) {
    let k = retina.mosaic.n_classes();
    let rows: Vec<&[f32]> = retina.mosaic.weights.chunks_exact(k).collect();
    let nn = rows.len();
    let mut taps: Vec<Vec<(u32, f32)>> = Vec::new();
    let mut planes = 0;
    for classes in opsin_blocks(&rows, k) {
        let members: Vec<usize> = (0..nn)
            .filter(|&i| classes.iter().any(|&c| rows[i][c] > EXPRESSED))
            .collect();
        let basis = row_space(&rows, &members, &classes);
        let coords: Vec<Vec<f64>> = members
            .iter()
            .map(|&i| {
                basis
                    .iter()
                    .map(|u| {
                        classes
                            .iter()
                            .zip(u)
                            .map(|(&c, uc)| rows[i][c] as f64 * uc)
                            .sum()
                    })
                    .collect()
            })
            .collect();
        let sigma_px = INTERPOLATION_SIGMA_SPACINGS * mean_spacing_px(retina, &members);
        let r = basis.len();
        let first = taps.len();
        taps.resize(first + r * nn, Vec::new());
        for j in 0..nn {
            let cell = cell_taps(retina, &members, &coords, j, sigma_px);
            for (p, t) in cell.into_iter().enumerate() {
                taps[first + p * nn + j] = t;
            }
        }
        planes += r;
    }
    (taps, planes)
}

/// The opsin classes grouped by shared cones, each block's classes ascending, blocks in the
/// order of their first class.
fn opsin_blocks(rows: &[&[f32]], k: usize) -> Vec<Vec<usize>> {
    let mut label: Vec<usize> = (0..k).collect();
    for row in rows {
        let expressed: Vec<usize> = (0..k).filter(|&c| row[c] > EXPRESSED).collect();
        if let Some(&first) = expressed.first() {
            for &c in &expressed[1..] {
                let (keep, drop) = (label[first].min(label[c]), label[first].max(label[c]));
                label
                    .iter_mut()
                    .filter(|l| **l == drop)
                    .for_each(|l| *l = keep);
            }
        }
    }
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    for c in 0..k {
        match blocks.iter_mut().find(|b| label[b[0]] == label[c]) {
            Some(b) => b.push(c),
            None => blocks.push(vec![c]),
        }
    }
    blocks
}

/// Orthonormal basis of the span of the members' weight rows restricted to `classes`, each
/// vector signed so its largest entry is positive.
fn row_space(rows: &[&[f32]], members: &[usize], classes: &[usize]) -> Vec<Vec<f64>> {
    let m = classes.len();
    let mut gram = vec![0.0; m * m];
    for &i in members {
        for (a, &ca) in classes.iter().enumerate() {
            for (b, &cb) in classes.iter().enumerate() {
                gram[a * m + b] += rows[i][ca] as f64 * rows[i][cb] as f64;
            }
        }
    }
    let (values, vectors) = symmetric_eigen(&gram, m);
    (0..m)
        .filter(|&d| values[d] > ROW_SPACE_CUTOFF * values[0])
        .map(|d| signed_eigenvector(&vectors, m, d))
        .collect()
}

/// The taps of each plane at cell `j`: `g_i (A⁻¹ u_i)_p` with `A = Σ g u uᵀ`, over the
/// smallest Gaussian neighbourhood (σ widened from `sigma_px`) whose `A` is well conditioned.
fn cell_taps(
    retina: &Retina,
    members: &[usize],
    coords: &[Vec<f64>],
    j: usize,
    sigma_px: f64,
) -> Vec<Vec<(u32, f32)>> {
    let r = coords[0].len();
    let mut sigma = sigma_px;
    for widening in 0..=MAX_WIDENINGS {
        let mut near = gaussian_neighbours(retina, members, j, sigma);
        if near.is_empty() && r == 1 {
            near.push((nearest(retina, members, j), 1.0));
        }
        let mut normal = vec![0.0; r * r];
        for &(m, g) in &near {
            for a in 0..r {
                for b in 0..r {
                    normal[a * r + b] += g * coords[m][a] * coords[m][b];
                }
            }
        }
        let (values, vectors) = symmetric_eigen(&normal, r);
        let conditioned = values[0] > 0.0 && values[r - 1] >= MIN_CONDITIONING * values[0];
        if conditioned || widening == MAX_WIDENINGS {
            // A⁻¹ = V diag(1/λ) Vᵀ, pseudo-inverse on the last try.
            let inverse: Vec<f64> = (0..r * r)
                .map(|ab| {
                    let (a, b) = (ab / r, ab % r);
                    (0..r)
                        .filter(|&d| values[d] > ROW_SPACE_CUTOFF * values[0])
                        .map(|d| vectors[a * r + d] * vectors[b * r + d] / values[d])
                        .sum()
                })
                .collect();
            return (0..r)
                .map(|p| {
                    near.iter()
                        .map(|&(m, g)| {
                            let w: f64 = (0..r).map(|b| inverse[p * r + b] * coords[m][b]).sum();
                            (members[m] as u32, (g * w) as f32)
                        })
                        .collect()
                })
                .collect();
        }
        sigma *= WIDENING;
    }
    unreachable!("the last widening returns")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::oracle::tests::{assert_percept_norms, eye, uniform};
    use crate::observer::oracle::{
        interpolation_taps, kinds_of, OracleDecoder, ORACLE_PERCEPT_DIM,
    };

    #[test]
    fn on_a_pure_mosaic_the_least_squares_taps_are_the_kind_means() {
        let retina = eye("LMS");
        let (taps, planes) = least_squares_taps(&retina);
        assert_eq!(planes, 3);
        let (kind_of, kinds) = kinds_of(&retina).unwrap();
        let by_kind = interpolation_taps(&retina, &kind_of, kinds);
        let k = retina.mosaic.n_classes();
        let nn = kind_of.len();
        for p in 0..3 {
            // Blocks come in class order, kinds in order of first appearance.
            let first_cone = retina
                .mosaic
                .weights
                .chunks_exact(k)
                .position(|row| row[p] > 0.5)
                .unwrap();
            let q = kind_of[first_cone];
            for j in 0..nn {
                let (a, b) = (&taps[p * nn + j], &by_kind[q * nn + j]);
                assert_eq!(a.len(), b.len(), "plane {p}, cell {j}: tap counts");
                for (x, y) in a.iter().zip(b) {
                    assert_eq!(x.0, y.0, "plane {p}, cell {j}: tap cells");
                    assert!(
                        (x.1 - y.1).abs() < 1e-6,
                        "plane {p}, cell {j}: {x:?} vs {y:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn random_ratios_give_an_ideal_three_plane_demosaicker() {
        let retina = eye("MS+L_ratio_M");
        let k = retina.mosaic.n_classes();
        assert_eq!(k, 3, "L, M and S");
        let oracle = OracleDecoder::new(&retina, true, 0).expect("least squares over mixtures");
        assert_eq!(oracle.kinds(), 3, "planes: L and M together (rank 2) and S");
        // A uniform field comes back exactly: |percept|² = |e|² (orthonormal U and embedding).
        let values = [0.7f32, 0.4, 0.9];
        let act = uniform(&retina, &values);
        let mut out = vec![0f32; ORACLE_PERCEPT_DIM * act.len()];
        oracle.decode(&act, &mut out);
        assert_percept_norms(&out, values.iter().map(|v| v * v).sum(), 1e-3);
        // Without interpolation there is no kind to keep per cell: still refused.
        assert!(OracleDecoder::new(&retina, false, 0).is_err());
    }

    #[test]
    fn a_block_whose_rows_are_all_one_mixture_has_one_plane() {
        // Every L- or M-expressing cone made ½L + ½M: the block {L, M} has rank 1, so L and M
        // cannot be told apart and the decoder gives two planes, not three.
        let mut retina = eye("MS+L_ratio_M");
        let k = retina.mosaic.n_classes();
        for row in retina.mosaic.weights.chunks_exact_mut(k) {
            if row[0] > 0.0 || row[1] > 0.0 {
                row.copy_from_slice(&[0.5, 0.5, 0.0]);
            }
        }
        let (taps, planes) = least_squares_taps(&retina);
        assert_eq!(planes, 2);
        let nn = retina.n() * retina.n();
        let act = uniform(&retina, &[0.7, 0.4, 0.9]);
        let value = |p: usize, j: usize| -> f32 {
            taps[p * nn + j]
                .iter()
                .map(|&(i, w)| w * act[i as usize])
                .sum()
        };
        let lm = (0.7 + 0.4) / 2f32.sqrt(); // e · (1, 1)/√2
        for j in 0..nn {
            assert!(
                (value(0, j) - lm).abs() < 1e-4,
                "cell {j}: {} vs {lm}",
                value(0, j)
            );
            assert!(
                (value(1, j) - 0.9).abs() < 1e-4,
                "cell {j}: S {}",
                value(1, j)
            );
        }
    }

    #[test]
    fn cells_among_one_mixture_widen_until_the_mixtures_determine_l_and_m() {
        // Left half: every L- or M-expressing cone ½L + ½M; right half: mixtures at the eye's
        // own random ratios. A left cell's first neighbourhood cannot tell L from M, so its σ
        // widens until it reaches the right half; a uniform field still comes back exactly.
        let mut retina = eye("MS+L_ratio_M");
        let k = retina.mosaic.n_classes();
        let half_px = retina.layout.field_px as f32 / 2.0;
        let positions = retina.layout.positions_px.clone();
        for (row, p) in retina.mosaic.weights.chunks_exact_mut(k).zip(&positions) {
            if p[0] < half_px && (row[0] > 0.0 || row[1] > 0.0) {
                row.copy_from_slice(&[0.5, 0.5, 0.0]);
            }
        }
        let (taps, planes) = least_squares_taps(&retina);
        assert_eq!(planes, 3, "the right half's mixtures still span L and M");
        let nn = retina.n() * retina.n();
        let values = [0.7f32, 0.4, 0.9];
        let act = uniform(&retina, &values);
        let norm2: f32 = values.iter().map(|v| v * v).sum();
        let (mut far, mut widened) = (0, 0);
        for j in 0..nn {
            let v2: f32 = (0..planes)
                .map(|p| {
                    let v: f32 = taps[p * nn + j]
                        .iter()
                        .map(|&(i, w)| w * act[i as usize])
                        .sum();
                    v * v
                })
                .sum();
            assert!(
                (v2 - norm2).abs() < 1e-3,
                "cell {j}: |planes|² {v2} vs {norm2}"
            );
            if positions[j][0] < half_px / 2.0 {
                // Far from the right half: its L/M taps must reach across.
                let reach = taps[j]
                    .iter()
                    .any(|&(i, _)| positions[i as usize][0] >= half_px);
                far += 1;
                widened += usize::from(reach);
            }
        }
        assert!(far > 0);
        assert_eq!(
            widened, far,
            "every far-left cell's L/M taps reach the mixtures"
        );
    }
}
