//! The colour-matching solver of CMF-SIM (paper S-04; docs/references.md#cmf-sim and #cmf-sim-defaults).
//!
//! For a test wavelength λ, primaries `p_1..p_K` (monochromatic, nm) and coefficients α (in
//! units of the test light's intensity I), the two patches are
//!
//! - side A at location `a`: the test light `(λ, I)` plus `(p_i, −α_i·I)` for every α_i < 0
//!   (a negative α adds that primary to the test side);
//! - side B at location `b`: `(p_i, α_i·I)` for every α_i > 0,
//!
//! and the residual is `r = Φ(B) − Φ(A)` (percepts). The error is `E(α) = mean_pairs ‖r‖²` over a
//! fixed list of location pairs, each side with a fixed noise seed (common random numbers, so
//! `E` is a deterministic function of α and finite differences work on noisy observers).
//!
//! α is found by Levenberg–Marquardt from α = 0 (the alternative to Adam in docs/references.md#cmf-sim-defaults):
//!
//! - **Jacobian.** Finite differences, one extra show per primary and pair on the side the
//!   primary is on: `J⁺_i = ∂Φ(B)/∂α_i` for α_i > 0, `J⁻_i = −∂Φ(A)/∂α_i` for α_i < 0, and both
//!   while α_i = 0. It is measured only after an accepted step (a rejected step reuses it).
//!   With [`MatchOptions::front_end`] the first step instead comes from a model measured once
//!   per location pair ([`FrontEndJacobians`]); if that step fails, differences at α = 0 take
//!   over, and convergence is only ever declared on a differenced Jacobian.
//! - **Kinks.** `r` is piecewise smooth with a kink at every α_i = 0 (the primary changes side,
//!   and the two sides are different locations). The step model uses the column of the side each
//!   α_i is on and never crosses a kink in one step: an α_i ≠ 0 keeps its side or stops at 0, an
//!   α_i = 0 stays or moves to either side ([`kink_step`]: ≤ 3^K small least-squares problems,
//!   the best sign-consistent one wins).
//! - **Step.** Gauss–Newton first (μ = 0, exact in one step for a linear, location-independent
//!   observer); after a failed step `(JᵀJ + μ·diag JᵀJ) δ = −Jᵀr`, with μ set by Nielsen's rule
//!   (grow ×2, ×4, … on failures; shrink by up to 3× when the model predicted the gain well),
//!   which moves towards gradient descent for nonlinear observers.
//! - **Stop** when an accepted step improves E by ≤ `rel_tolerance` of E, when E ≤
//!   `exact_match_rel · E(0)`, after `max_iterations` evaluations, or — if the caller passes a
//!   threshold ([`MatchOptions::stop_below`]) — as soon as E is below it (CMF-SIM only needs to
//!   know that a match below the threshold exists). Such a solve can be continued later
//!   ([`MatchOptions::resume`]) along exactly the path an uninterrupted solve takes.
//! - **Known percepts.** [`MatchOptions::known_at_zero`] supplies Φ(A), Φ(B) at α = 0 (CMF-SIM's
//!   base step showed them already).
//!
//! All wavelengths being solved advance in lockstep, so each iteration is two batched
//! [`Observer::percepts`] calls (Jacobian shows, then trial shows).

use serde::{Deserialize, Serialize};

use crate::linalg::{lstsq, DEFAULT_RCOND};
use crate::observer::{Observer, Show, Stimulus};

mod front_end;
mod kink;
mod shows;
mod state;
#[cfg(test)]
pub(crate) mod tests;

pub use front_end::{FrontEndJacobians, TestPercepts};
pub use kink::{kink_step, ModelStep};
use shows::{initial_percepts, jacobian_pass, trial_pass, Batch};
use state::State;

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSettings {
    /// Maximum LM iterations (trial evaluations) per wavelength.
    pub max_iterations: usize,
    /// Finite-difference step, in units of the test intensity.
    pub fd_step: f64,
    /// Stop when an accepted step improves E by less than this fraction (chosen here: a
    /// Levenberg–Marquardt step in place of Adam with a relative-improvement stop,
    /// docs/references.md#cmf-sim-defaults).
    pub rel_tolerance: f64,
    /// Stop when E falls below this fraction of E(0) (an exact match).
    pub exact_match_rel: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            max_iterations: 12,
            fd_step: 1e-3,
            rel_tolerance: 1e-4,
            exact_match_rel: 1e-14,
        }
    }
}

/// One matching problem: test wavelengths against one primary set.
pub struct MatchProblem<'a> {
    /// The observer.
    pub observer: &'a dyn Observer,
    /// Test wavelengths, nm.
    pub test_wavelengths_nm: &'a [f64],
    /// Primary wavelengths, nm.
    pub primaries_nm: &'a [f64],
    /// Test-light intensity I (the unit of α).
    pub intensity: f64,
    /// Per test wavelength, the location pairs `[a, b]`.
    pub pairs: &'a [Vec<[[f64; 2]; 2]>],
    /// Base of the per-show noise seeds: side A of (wavelength w, pair p) uses
    /// `show_seed(seed, w, p, 1)`, side B `show_seed(seed, w, p, 2)`.
    pub seed: u64,
}

/// Percepts already measured at α = 0 with the problem's locations and seeds, row-major
/// `(wavelengths × pairs × N)`: side A is the test light at `a`, side B is black at `b`.
#[derive(Debug, Clone, Copy)]
pub struct KnownAtZero<'a> {
    /// Φ(test light at a).
    pub side_a: &'a [f64],
    /// Φ(black at b).
    pub side_b: &'a [f64],
}

/// Optional inputs of [`solve_wavelengths`].
#[derive(Debug, Clone, Copy, Default)]
pub struct MatchOptions<'a> {
    /// Per test wavelength (indexed like `test_wavelengths_nm`): stop as soon as E is below this
    /// value. The α and E returned are then the first iterate below it, not the optimum.
    pub stop_below: Option<&'a [f64]>,
    /// Percepts at α = 0 that need not be shown again.
    pub known_at_zero: Option<KnownAtZero<'a>>,
    /// The first step's model through the observer's linear front end (for the wavelengths it
    /// holds; the others start from α-space differences at α = 0).
    pub front_end: Option<&'a FrontEndJacobians>,
    /// Earlier solves of (some of) the same wavelengths of the same problem and settings: those
    /// that stopped below a threshold continue where they stopped, the others are final (the
    /// result equals an uninterrupted solve).
    pub resume: Option<&'a [WavelengthMatch]>,
}

/// The solution for one test wavelength.
#[derive(Debug, Clone, PartialEq)]
pub struct WavelengthMatch {
    /// Index of the test wavelength.
    pub wavelength: usize,
    /// α (K values).
    pub alpha: Vec<f64>,
    /// E(α).
    pub error: f64,
    /// E(0): the percept energy of the test light against black.
    pub error_at_zero: f64,
    /// Trial evaluations made.
    pub iterations: usize,
    /// True when the solve stopped because E fell below [`MatchOptions::stop_below`].
    pub stopped_below: bool,
    /// What [`MatchOptions::resume`] needs to continue a solve that stopped below a threshold.
    pub resume: Option<Resume>,
}

/// The solver state of a wavelength that stopped below its threshold.
#[derive(Debug, Clone, PartialEq)]
pub struct Resume {
    /// LM damping μ and Nielsen's growth factor ν.
    pub mu: f64,
    /// ν.
    pub nu: f64,
    /// Φ(A), Φ(B) at α, `(pairs × N)`.
    pub side_a: Vec<f64>,
    /// Φ(B).
    pub side_b: Vec<f64>,
}

/// What [`solve_wavelengths`] returns.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchReport {
    /// One entry per requested wavelength, in the order requested.
    pub matches: Vec<WavelengthMatch>,
    /// Batched observer calls made.
    pub observer_calls: usize,
    /// Single shows evaluated.
    pub shows: usize,
}

/// The solution for every test wavelength ([`solve_matches`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MatchSolution {
    /// α per test wavelength (K values each).
    pub alphas: Vec<Vec<f64>>,
    /// Final error E(α) per test wavelength.
    pub errors: Vec<f64>,
    /// E(0) per test wavelength (the percept energy of the test light against black).
    pub errors_at_zero: Vec<f64>,
    /// Batched observer calls made.
    pub observer_calls: usize,
    /// Single shows evaluated.
    pub shows: usize,
}

/// Noise seed of one (wavelength, pair, side) triple.
pub fn show_seed(base: u64, wavelength: usize, pair: usize, side: u64) -> u64 {
    let mut z = base ^ ((wavelength as u64) << 40) ^ ((pair as u64) << 8) ^ side;
    // splitmix64 finaliser
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

/// Solve the wavelengths `which` (indices into `pb.test_wavelengths_nm`) of `pb`.
///
/// # Panics
/// If `pb.pairs` does not have one list per test wavelength, an index is out of range, or the
/// known percepts do not have `(wavelengths × pairs × N)` values.
pub fn solve_wavelengths(
    pb: &MatchProblem<'_>,
    settings: &SolverSettings,
    which: &[usize],
    options: &MatchOptions<'_>,
) -> MatchReport {
    let nw = pb.test_wavelengths_nm.len();
    assert_eq!(
        pb.pairs.len(),
        nw,
        "solve_wavelengths: {} pair lists for {nw} wavelengths",
        pb.pairs.len()
    );
    let n = pb.observer.percept_dim();
    let mut batch = Batch::new(pb, settings.fd_step);
    let mut states: Vec<State> = which
        .iter()
        .map(|&w| {
            assert!(w < nw, "solve_wavelengths: wavelength {w} of {nw}");
            State::new(w, pb.primaries_nm.len(), pb.pairs[w].len(), n)
        })
        .collect();
    initial_percepts(pb, options, &mut batch, &mut states);
    let classes: Option<Vec<Vec<f64>>> = options.front_end.map(|f| {
        pb.primaries_nm
            .iter()
            .map(|&p| {
                let c = f.class_vector(pb.observer.grid(), p);
                c.into_iter().map(|v| v * pb.intensity).collect()
            })
            .collect()
    });
    for s in states.iter_mut().filter(|s| !s.resumed) {
        s.start(options.stop_below.map(|t| t[s.w]), settings.max_iterations);
        if let (Some(f), Some(c)) = (options.front_end, &classes) {
            if s.active {
                s.j_valid = s.model_from(f, c);
            }
        }
    }

    // Every active state makes one trial per pass and stops at max_iterations.
    while states.iter().any(|s| s.active) {
        jacobian_pass(pb, settings, &mut batch, &mut states);
        trial_pass(pb, settings, options, &mut batch, &mut states);
    }
    MatchReport {
        matches: states.into_iter().map(State::finish).collect(),
        observer_calls: batch.calls,
        shows: batch.total,
    }
}

/// Solve every test wavelength of `pb` to convergence.
pub fn solve_matches(pb: &MatchProblem<'_>, settings: &SolverSettings) -> MatchSolution {
    let all: Vec<usize> = (0..pb.test_wavelengths_nm.len()).collect();
    let r = solve_wavelengths(pb, settings, &all, &MatchOptions::default());
    MatchSolution {
        errors: r.matches.iter().map(|m| m.error).collect(),
        errors_at_zero: r.matches.iter().map(|m| m.error_at_zero).collect(),
        alphas: r.matches.into_iter().map(|m| m.alpha).collect(),
        observer_calls: r.observer_calls,
        shows: r.shows,
    }
}

/// Least-squares helper shared with [`state`]: minimum-norm `x` of `A·x ≈ b`.
fn solve_small(a: &[f64], rows: usize, cols: usize, b: &[f64]) -> Vec<f64> {
    lstsq(a, rows, cols, b, 1, DEFAULT_RCOND).x
}
