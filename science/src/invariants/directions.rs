//! Which colour directions the percept carries: the held-out recovery of each principal
//! direction of the eye's cone excitations (paper §4–§6: an N-D colour vision is a percept that
//! keeps N independent combinations of the cone classes apart across the retina). Evaluation
//! only: this reads the true excitations of held-out scenes; nothing here feeds learning.
//!
//! [`super::hidden`] asks, per class, how much of what that class tells *beyond all the others*
//! the percept carries. Where three classes have close peaks (M 530, Q 545, L 560 nm) each one's
//! own part is a fraction of a percent of its variance and near zero in every percept, although
//! the L−M-like contrast across the three — shared by them, unique to none — is what a third
//! dimension rests on. This measure asks about directions instead of classes:
//! 1. over every site inside the loss border of the held-out samples, the true excitations of
//!    the `K` classes, each standardised (zero mean, unit variance over the sites);
//! 2. their principal directions: the eigenvectors of the `K×K` correlation matrix, strongest
//!    first, each with its **share** of the total variance (eigenvalue / `K`). In natural
//!    scenes the first is luminance-like (all classes with one sign); the later ones are the
//!    opponent contrasts, weakest last;
//! 3. per direction, an affine least-squares map from the percept to the projection on it,
//!    fitted on the first half of the samples; its **R²** on the second half (held out; can be
//!    negative for a map that does worse than the mean).
//!
//! 1 means the percept carries that combination of the classes at every cone; 0 means it does
//! not carry it at all. A percept of `D` independent channels can carry at most `D` directions;
//! a trichromat's percept that keeps the red–green contrast has the third R² high, one that has
//! lost it low whatever its per-class figures say.

use super::hidden::{column_standardisation, held_out_r2, ratio, HiddenSamples};
use colorimetry::linalg::{signed_eigenvector, symmetric_eigen};
use serde::{Deserialize, Serialize};

/// The principal directions of the cone excitations and how well the percept carries each.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DirectionRecovery {
    /// Class names in the order of each direction's weights.
    pub classes: Vec<String>,
    /// Per direction, strongest first: the weights on the standardised classes (unit length;
    /// the sign makes the largest weight positive).
    pub weights: Vec<Vec<f64>>,
    /// Per direction: its share of the standardised excitations' variance (the shares sum to 1).
    pub share: Vec<f64>,
    /// Per direction: the held-out R² of the percept's affine fit to the projection on it.
    #[serde(deserialize_with = "super::nan_for_null")]
    pub r2: Vec<f64>,
}

impl DirectionRecovery {
    /// Each direction as its weights in words, e.g. `+0.58L +0.58M +0.57S`.
    pub fn describe_weights(&self) -> Vec<String> {
        self.weights
            .iter()
            .map(|w| {
                w.iter()
                    .zip(&self.classes)
                    .map(|(v, c)| format!("{v:+.2}{c}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect()
    }
}

/// Measures the direction recovery of `samples` (module docs): principal directions over all
/// samples, fits on the first half, scores on the rest.
///
/// # Panics
/// If `names` does not have one name per class or there are fewer than 2 samples.
pub fn measure_directions(samples: &HiddenSamples, names: &[String]) -> DirectionRecovery {
    let (k, dim) = (samples.classes(), samples.dim());
    assert_eq!(
        names.len(),
        k,
        "measure_directions: {} names for {k} classes",
        names.len()
    );
    let count = samples.len();
    assert!(
        count >= 2,
        "measure_directions: needs at least 2 samples (fit and score), has {count}"
    );
    let (fit_percept, fit_excitation) = samples.all_sites(0..count / 2);
    let (score_percept, score_excitation) = samples.all_sites(count / 2..count);
    let all: Vec<f64> = fit_excitation
        .iter()
        .chain(&score_excitation)
        .copied()
        .collect();
    let (mean, scale) = column_standardisation(&all, k);
    let (values, vectors) = symmetric_eigen(&correlation(&all, k, &mean, &scale), k);
    let total: f64 = values.iter().map(|v| v.max(0.0)).sum();
    let mut weights = Vec::with_capacity(k);
    let mut r2 = Vec::with_capacity(k);
    for d in 0..k {
        let w = signed_eigenvector(&vectors, k, d);
        let project = |e: &[f64]| -> Vec<f64> {
            e.chunks_exact(k)
                .map(|row| (0..k).map(|c| (row[c] - mean[c]) * scale[c] * w[c]).sum())
                .collect()
        };
        r2.push(held_out_r2(
            (&fit_percept, &project(&fit_excitation)),
            (&score_percept, &project(&score_excitation)),
            dim,
        ));
        weights.push(w);
    }
    DirectionRecovery {
        classes: names.to_vec(),
        weights,
        share: values.iter().map(|v| ratio(v.max(0.0), total)).collect(),
        r2,
    }
}

/// The `k×k` covariance (row-major) of the standardised columns: their correlation matrix.
fn correlation(values: &[f64], k: usize, mean: &[f64], scale: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; k * k];
    let mut rows = 0usize;
    for row in values.chunks_exact(k) {
        let z: Vec<f64> = (0..k).map(|c| (row[c] - mean[c]) * scale[c]).collect();
        for a in 0..k {
            for b in 0..k {
                out[a * k + b] += z[a] * z[b];
            }
        }
        rows += 1;
    }
    out.iter_mut().for_each(|v| *v /= rows.max(1) as f64);
    out
}

#[cfg(test)]
mod tests {
    use super::super::hidden::tests::{measure_samples, N};
    use super::*;

    fn directions_of(
        dim: usize,
        percept: impl Fn(&[f32], &[usize]) -> Vec<f32>,
    ) -> DirectionRecovery {
        let samples = measure_samples(dim, percept);
        let names: Vec<String> = ["L", "M", "S"].iter().map(|s| s.to_string()).collect();
        measure_directions(&samples, &names)
    }

    #[test]
    fn the_true_excitations_carry_every_direction_and_a_luminance_percept_only_the_first() {
        let full = directions_of(3, |ex, _| ex.to_vec());
        assert!(full.r2.iter().all(|r| *r > 0.999), "{full:?}");
        let shares: f64 = full.share.iter().sum();
        assert!((shares - 1.0).abs() < 1e-9, "{full:?}");
        assert!(
            full.share.windows(2).all(|p| p[0] >= p[1]),
            "strongest first: {full:?}"
        );
        // The first direction of these scenes is luminance-like: every weight positive.
        assert!(full.weights[0].iter().all(|w| *w > 0.2), "{full:?}");
        // One channel of L + M: the first direction largely, the weakest (L − M here) not at all
        // (held out, "not at all" can read a little below 0).
        let lum = directions_of(1, |ex, _| {
            let nn = N * N;
            (0..nn).map(|i| ex[i] + ex[nn + i]).collect()
        });
        assert!(lum.r2[0] > 0.8, "{lum:?}");
        assert!(lum.r2[2] < 0.05, "{lum:?}");
    }

    #[test]
    fn a_dichromat_percept_loses_one_direction_and_a_mosaic_copy_loses_most() {
        // L and M everywhere, S dropped: two directions carried, one not.
        let dichromat = directions_of(2, |ex, _| ex[..2 * N * N].to_vec());
        let mut r2 = dichromat.r2.clone();
        r2.sort_by(f64::total_cmp);
        assert!(r2[0] < 0.3, "one direction lost: {dichromat:?}");
        assert!(r2[1] > 0.6, "two carried: {dichromat:?}");
        // Each class only at its own cones: the opponent directions are not carried.
        let mosaic = directions_of(3, |ex, class| {
            let nn = N * N;
            let mut p = vec![0f32; 3 * nn];
            for (i, &c) in class.iter().enumerate() {
                p[c * nn + i] = ex[c * nn + i];
            }
            p
        });
        assert!(
            mosaic.r2[1] < 0.5 && mosaic.r2[2] < 0.5,
            "a mosaic copy carries little of the opponent directions: {mosaic:?}"
        );
    }
}
