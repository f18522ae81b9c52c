//! What the eye hides, recovered: how much of each cone class's *own* signal the percept carries
//! at the cones of the other classes (paper §4: the demosaicker D "fills in" the colour the mosaic
//! leaves out). Evaluation only: this reads the true excitations and classes of held-out scenes;
//! nothing here feeds learning.
//!
//! At a cone of class j the eye measures class j alone; what class k ≠ j would have caught there
//! is hidden. In natural scenes the classes are strongly correlated (L predicts most of M and
//! much of S), so a percept that carries only luminance already predicts every class well. The
//! measure removes that part:
//! 1. at each hidden site of class k (a cone whose dominant class is not k, inside the loss
//!    border), the **unique part** `u_k = e_k − (affine least-squares prediction of e_k from the
//!    other classes' true excitations at the same place)`: what class k tells beyond the others;
//! 2. an affine least-squares map from the `N`-dimensional percept to `u_k`, fitted on the first
//!    half of the held-out samples;
//! 3. the **unique recovery** of class k: the fraction of `u_k`'s variance that map explains on
//!    the second half (R², held out; can be negative for a map that does worse than the mean).
//!
//! 1 means the percept carries class k's own signal everywhere, as an oracle demosaicker does;
//! 0 means it carries only what the other classes already tell (a (K−1)-class percept), or class
//! k only where its own cones are. For a trichromat the S figure is the third dimension's
//! carrier across the mosaic, the L and M figures the red–green one. A class with no hidden
//! site (a monochromat) or no other class has no figure (NaN, `null` in JSON).

use colorimetry::linalg::lstsq;
use serde::{Deserialize, Serialize};

/// Per class, the unique recovery at its hidden sites (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HiddenRecovery {
    /// Class names in the order of `unique_r2`.
    pub classes: Vec<String>,
    /// Held-out R² of the percept's affine fit to each class's unique part at its hidden sites.
    #[serde(deserialize_with = "super::nan_for_null")]
    pub unique_r2: Vec<f64>,
    /// Per class, the unique part's share of the class's variance at its hidden sites: how much
    /// of the class the scenes leave to be told apart from the others (a property of the scenes,
    /// not of the cortex; NaN where there is no figure).
    #[serde(default, deserialize_with = "super::nan_for_null")]
    pub unique_share: Vec<f64>,
    /// Held-out sites the figure of each class was evaluated on.
    pub sites: Vec<usize>,
    /// Held-out scenes behind the figures, half fitting and half scoring (`None` in a record
    /// written before the count was kept: 32 scenes cut from a pool of 32 reused tiles, too few
    /// where a class's own signal lives in rare tiles;
    /// docs/notebook/2026-12-05-hidden-signal-convergence.md).
    #[serde(default)]
    pub scenes: Option<usize>,
}

/// Held-out samples of percepts and true excitations at the cones, gathered per sample.
#[derive(Clone, Debug, Default)]
pub struct HiddenSamples {
    /// Per sample, rows `(sites, dim)` of the percept.
    percept: Vec<Vec<f64>>,
    /// Per sample, rows `(sites, classes)` of the true excitations.
    excitation: Vec<Vec<f64>>,
    /// Per sample, the dominant class of each site.
    class: Vec<Vec<usize>>,
    dim: usize,
    classes: usize,
}

impl HiddenSamples {
    /// An empty collection for `dim`-channel percepts of an eye with `classes` classes.
    pub fn new(dim: usize, classes: usize) -> Self {
        HiddenSamples {
            dim,
            classes,
            ..Default::default()
        }
    }

    /// Adds one sample: `percept (dim, n, n)`, `excitation (classes, n, n)`, `class (n²)`; the
    /// sites are the cones at least `border` cells from the lattice edge, every
    /// [`site_stride`]-th in each direction (at most 16 × 16 of them: [`MAX_SITES_PER_SAMPLE`]).
    pub fn add(
        &mut self,
        percept: &[f32],
        excitation: &[f32],
        class: &[usize],
        n: usize,
        border: usize,
    ) {
        let nn = n * n;
        assert!(
            percept.len() == self.dim * nn
                && excitation.len() == self.classes * nn
                && class.len() == nn,
            "HiddenSamples::add: percept {} (dim {}), excitation {} (classes {}), class {} for n = {n}",
            percept.len(),
            self.dim,
            excitation.len(),
            self.classes,
            class.len()
        );
        let (mut p, mut e, mut c) = (Vec::new(), Vec::new(), Vec::new());
        let inside = border..n.saturating_sub(border);
        let stride = site_stride(inside.len());
        for y in inside.clone().step_by(stride) {
            for x in inside.clone().step_by(stride) {
                let i = y * n + x;
                p.extend((0..self.dim).map(|d| percept[d * nn + i] as f64));
                e.extend((0..self.classes).map(|k| excitation[k * nn + i] as f64));
                c.push(class[i]);
            }
        }
        self.percept.push(p);
        self.excitation.push(e);
        self.class.push(c);
    }

    /// Sites kept per sample (the same for every sample of one eye and border).
    pub fn sites_per_sample(&self) -> usize {
        self.class.first().map_or(0, Vec::len)
    }

    /// Percept channels per site.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Cone classes per site.
    pub fn classes(&self) -> usize {
        self.classes
    }

    /// Samples added.
    pub fn len(&self) -> usize {
        self.percept.len()
    }

    /// Whether no sample was added.
    pub fn is_empty(&self) -> bool {
        self.percept.is_empty()
    }

    /// Every site of `samples`, hidden or not: the percepts, row-major `(sites, dim)`, and the
    /// true excitations, `(sites, classes)`.
    pub fn all_sites(&self, samples: std::ops::Range<usize>) -> (Vec<f64>, Vec<f64>) {
        let percept = self.percept[samples.clone()].concat();
        let excitation = self.excitation[samples].concat();
        (percept, excitation)
    }

    /// The unique recovery of every class (module docs), fitted on the first half of the
    /// samples and scored on the rest.
    pub fn measure(&self, names: &[String]) -> HiddenRecovery {
        assert_eq!(
            names.len(),
            self.classes,
            "HiddenSamples::measure: {} names for {} classes",
            names.len(),
            self.classes
        );
        assert!(
            self.percept.len() >= 2,
            "HiddenSamples::measure: needs at least 2 samples (fit and score), has {}",
            self.percept.len()
        );
        let half = self.percept.len() / 2;
        let mut unique_r2 = Vec::with_capacity(self.classes);
        let mut unique_share = Vec::with_capacity(self.classes);
        let mut sites = Vec::with_capacity(self.classes);
        for k in 0..self.classes {
            let fit = self.hidden_rows(k, 0..half);
            let score = self.hidden_rows(k, half..self.percept.len());
            sites.push(score.rows());
            let (r2, share) = match (self.classes > 1, fit.rows() > 0, score.rows() > 0) {
                (true, true, true) => unique_r2_of(&fit, &score, self.dim, self.classes - 1),
                _ => (f64::NAN, f64::NAN),
            };
            unique_r2.push(r2);
            unique_share.push(share);
        }
        HiddenRecovery {
            classes: names.to_vec(),
            unique_r2,
            unique_share,
            sites,
            scenes: Some(self.percept.len()),
        }
    }

    /// Rows of the hidden sites of class `k` in `samples`.
    fn hidden_rows(&self, k: usize, samples: std::ops::Range<usize>) -> Rows {
        let mut rows = Rows::default();
        for s in samples {
            for (i, &c) in self.class[s].iter().enumerate() {
                if c == k {
                    continue;
                }
                let e = &self.excitation[s][i * self.classes..(i + 1) * self.classes];
                rows.target.push(e[k]);
                rows.others.extend(
                    e.iter()
                        .enumerate()
                        .filter(|&(j, _)| j != k)
                        .map(|(_, &v)| v),
                );
                rows.percept
                    .extend_from_slice(&self.percept[s][i * self.dim..(i + 1) * self.dim]);
            }
        }
        rows
    }
}

/// Most sites one held-out sample keeps: a 16 × 16 grid of cones. Neighbouring cones of one
/// scene say nearly the same about the percept, so the figures rest on the number of scenes: on
/// 1 024 scenes of a kept quick cortex (`results/humanq-H0-seed51`, two independent streams)
/// every class's figure with every cone inside the border (3 364 a scene) and with every fourth
/// in each direction (225) differ by at most 0.009, while the two streams differ by up to 0.033
/// (docs/notebook/2026-12-05-hidden-signal-convergence.md). It keeps a measure on 1 024 scenes
/// of any eye within about 110–140 MiB at the presets' 8 percept channels
/// (`crate::budget::held_out_bytes`), so a run's summary reads the converged count.
pub const MAX_SITES_PER_SAMPLE: usize = 16 * 16;

/// The step between the kept sites of a sample, in cones along each direction, for `side`
/// cones inside the border: the smallest that keeps at most [`MAX_SITES_PER_SAMPLE`].
pub fn site_stride(side: usize) -> usize {
    (1..)
        .find(|s| side.div_ceil(*s).pow(2) <= MAX_SITES_PER_SAMPLE)
        .expect("a stride as large as the side keeps one site")
}

/// The hidden sites of one class: target excitation, the other classes' excitations, percept.
#[derive(Default)]
struct Rows {
    target: Vec<f64>,
    others: Vec<f64>,
    percept: Vec<f64>,
}

impl Rows {
    fn rows(&self) -> usize {
        self.target.len()
    }
}

/// Relative singular-value cut-off of the fits: directions of the standardised inputs this much
/// weaker than the strongest are dropped, so a nearly dead percept channel cannot carry a huge
/// coefficient from the fitting half to the scoring half.
const FIT_RCOND: f64 = 1e-6;

/// Affine least squares `y ≈ x·β + c` on `fit`, applied to `apply`: the residuals there. The
/// columns are standardised on `fit` first (the solution is the same up to the cut-off).
pub(crate) fn affine_residuals(
    fit: (&[f64], &[f64]),
    apply: (&[f64], &[f64]),
    cols: usize,
) -> Vec<f64> {
    let (xf, yf) = fit;
    let (xa, ya) = apply;
    let rows = yf.len();
    let (mean, scale) = column_standardisation(xf, cols);
    let design = |x: &[f64]| -> Vec<f64> {
        let mut out = Vec::with_capacity(x.len() / cols.max(1) * (cols + 1));
        for r in x.chunks_exact(cols) {
            out.extend((0..cols).map(|c| (r[c] - mean[c]) * scale[c]));
            out.push(1.0);
        }
        out
    };
    let beta = lstsq(&design(xf), rows, cols + 1, yf, 1, FIT_RCOND).x;
    design(xa)
        .chunks_exact(cols + 1)
        .zip(ya)
        .map(|(r, y)| y - r.iter().zip(&beta).map(|(a, b)| a * b).sum::<f64>())
        .collect()
}

/// Held-out R² of the percept's affine fit to the unique part (module docs, steps 1–3). The
/// unique part is defined by one regression on the others over both halves together (it is a
/// property of the scenes, not of the cortex). Also returns the unique part's share of the
/// target's variance over both halves.
fn unique_r2_of(fit: &Rows, score: &Rows, dim: usize, others: usize) -> (f64, f64) {
    let all_others: Vec<f64> = fit.others.iter().chain(&score.others).copied().collect();
    let all_target: Vec<f64> = fit.target.iter().chain(&score.target).copied().collect();
    let unique = affine_residuals(
        (&all_others, &all_target),
        (&all_others, &all_target),
        others,
    );
    let (u_fit, u_score) = unique.split_at(fit.rows());
    let r2 = held_out_r2((&fit.percept, u_fit), (&score.percept, u_score), dim);
    (r2, ratio(variance(&unique), variance(&all_target)))
}

/// Held-out R² of an affine least-squares map from `dim`-column rows to a target: fitted on
/// `fit = (x, y)`, scored on `score`, as 1 − residual variance / the target's variance there
/// (NaN for a constant target).
pub fn held_out_r2(fit: (&[f64], &[f64]), score: (&[f64], &[f64]), dim: usize) -> f64 {
    let residual = affine_residuals(fit, score, dim);
    let left = residual.iter().map(|r| r * r).sum::<f64>() / residual.len() as f64;
    1.0 - ratio(left, variance(score.1))
}

/// Per column of row-major `(rows, cols)` values: the mean and the inverse standard deviation
/// (0 for a constant column, which then carries no weight).
pub(super) fn column_standardisation(values: &[f64], cols: usize) -> (Vec<f64>, Vec<f64>) {
    let rows = (values.len() / cols.max(1)).max(1) as f64;
    let column = |c: usize| values.iter().skip(c).step_by(cols);
    let mean: Vec<f64> = (0..cols).map(|c| column(c).sum::<f64>() / rows).collect();
    let scale = (0..cols)
        .map(|c| {
            let var = column(c).map(|x| (x - mean[c]).powi(2)).sum::<f64>() / rows;
            if var > 0.0 {
                1.0 / var.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    (mean, scale)
}

/// The population variance of `v`.
fn variance(v: &[f64]) -> f64 {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64
}

/// `a / b`, NaN where `b` is not positive.
pub(super) fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 {
        a / b
    } else {
        f64::NAN
    }
}

#[cfg(test)]
pub(super) mod tests;
