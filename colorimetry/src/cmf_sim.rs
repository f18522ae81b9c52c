//! CMF-SIM: the colour dimensionality of a black-box observer (paper S-04; docs/references.md#cmf-sim).
//!
//! 1. Base error per test wavelength λ (100 from 400 to 700 nm): the same monochromatic light
//!    shown at the two patches of random location pairs, `base(λ) = mean ‖Φ(t@b) − Φ(t@a)‖²`.
//!    The percept energy `energy(λ) = mean ‖Φ(black@b) − Φ(t@a)‖²` is the 0-primary error.
//!    If `Σ base ≥ Σ energy` the observer has no colour constancy (paper S-05, baseline 1): the
//!    dimension is undefined (reported as 0) and no search is run.
//! 2. K = 1, 2, …: draw up to `sets_per_k` stratified primary sets (K equal bands of the primary
//!    range, one uniform draw per band, sets with two primaries within
//!    `min_primary_separation_nm` redrawn without counting), solve α per λ
//!    ([`crate::matching`]), and pass the set when for every λ
//!    `error(λ) < pass_ratio · max(base(λ), floor)`. With `early_rejection` (default) a set is
//!    rejected at the first wavelength whose converged error reaches its threshold, visiting the
//!    wavelengths where earlier sets failed first ([`sets`]); the verdicts are those of full
//!    evaluation.
//! 3. The dimension is the first K with a passing set.
//!
//! With `reuse_base_pairs` the matches use the base step's locations and noise seeds, so the
//! percepts at α = 0 (test light at a, black at b) are the base step's and are not shown again,
//! and — for observers with a linear front end — the first step of every set comes from a model
//! measured once per location pair ([`FrontEndJacobians`]).
//!
//! Files: `base` (step 1), `search` (step 2 for one K), `candidates` (converging a failed K's
//! candidates best first), [`sets`] (evaluating one set), `types` (settings and results).
//!
//! The floor `base_error_floor_rel · max_λ energy(λ)` exists for noise-free observers whose base
//! error is exactly 0 (every analytic observer here): an exact match then has an error at
//! rounding level (~1e-30 of the energy), a failed one an error of order the energy, and the
//! floor (default 1e-8 of the energy) separates the two. For trained, noisy observers the base
//! error is far above the floor and the floor plays no role.
//!
//! Output: [`CmfSimResult`], serialised to `cmf_sim.json` (top-level integer `dimension`) with
//! per-wavelength errors for 0..K primaries, their areas, the sets tried per K (each with the
//! number of wavelengths solved) and the verdict; [`CmfSimResult::error_plot`] draws the paper's
//! Fig. 4/8 curves. Every reported curve is solved at every wavelength to convergence
//! (`fully_evaluated`): at the passing K the first passing set, at a failed K the rejected set
//! with the lowest worst ratio over the wavelengths it was tested on.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use rand::{Rng, RngCore, SeedableRng};

use crate::error::{ColorimetryError, Result};
use crate::grid::WavelengthGrid;
use crate::matching::{FrontEndJacobians, TestPercepts};
use crate::observer::Observer;

mod base;
mod candidates;
mod search;
pub mod sets;
mod types;

pub use types::{CmfSimProgress, CmfSimResult, CmfSimSettings, ErrorCurve, KSummary, SetRecord};

use base::base_errors;
use search::Search;
use sets::{FrontEnd, SetOutcome, WavelengthOrder};

/// Largest number of primaries CMF-SIM tries (the sets per K grow as bands multiply).
pub const MAX_PRIMARIES: usize = 8;

/// Trapezoid ∫ y dx.
pub fn trapezoid(xs: &[f64], ys: &[f64]) -> f64 {
    xs.windows(2)
        .zip(ys.windows(2))
        .map(|(x, y)| 0.5 * (x[1] - x[0]) * (y[0] + y[1]))
        .sum()
}

/// Draw a stratified primary set: K equal bands of `range`, one uniform draw each, redrawn until
/// no two are closer than `min_sep_nm` (at most 10 000 attempts).
pub fn stratified_primaries(
    k: usize,
    range: (f64, f64),
    min_sep_nm: f64,
    rng: &mut dyn RngCore,
) -> Result<Vec<f64>> {
    let width = (range.1 - range.0) / k as f64;
    for _ in 0..10_000 {
        let p: Vec<f64> = (0..k)
            .map(|i| range.0 + width * (i as f64 + rng.random::<f64>()))
            .collect();
        if p.windows(2).all(|w| w[1] - w[0] >= min_sep_nm) {
            return Ok(p);
        }
    }
    Err(ColorimetryError::setting(
        "min_primary_separation_nm",
        format!("no {k} primaries in {range:?} nm are {min_sep_nm} nm apart"),
    ))
}

/// Check every setting against the observer's grid (errors name the field).
pub fn validate_settings(settings: &CmfSimSettings, grid: &WavelengthGrid) -> Result<()> {
    let s = settings;
    let bad = |n: &str, m: String| Err(ColorimetryError::setting(n, m));
    for (name, v, least) in [
        ("n_test_wavelengths", s.n_test_wavelengths, 2),
        ("location_pairs", s.location_pairs, 1),
        ("sets_per_k", s.sets_per_k, 1),
        ("max_primaries", s.max_primaries, 1),
        ("first_round_wavelengths", s.first_round_wavelengths, 1),
        ("converged_sets", s.converged_sets, 1),
        ("solver.max_iterations", s.solver.max_iterations, 1),
    ] {
        if v < least {
            return bad(name, format!("{v} (must be ≥ {least})"));
        }
    }
    if s.margins_through_k > s.max_primaries {
        return bad(
            "margins_through_k",
            format!(
                "{} (at most max_primaries, {})",
                s.margins_through_k, s.max_primaries
            ),
        );
    }
    if s.max_primaries > MAX_PRIMARIES {
        return bad(
            "max_primaries",
            format!("{} (at most {MAX_PRIMARIES})", s.max_primaries),
        );
    }
    for (name, v) in [
        ("pass_ratio", s.pass_ratio),
        ("solver.fd_step", s.solver.fd_step),
        ("intensity", s.intensity.unwrap_or(1.0)),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return bad(name, format!("{v} (must be positive and finite)"));
        }
    }
    for (name, v) in [
        ("base_error_floor_rel", s.base_error_floor_rel),
        ("min_primary_separation_nm", s.min_primary_separation_nm),
        ("solver.rel_tolerance", s.solver.rel_tolerance),
        ("solver.exact_match_rel", s.solver.exact_match_rel),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return bad(name, format!("{v} (must be ≥ 0 and finite)"));
        }
    }
    for (name, (lo, hi)) in [
        ("test_range_nm", s.test_range_nm),
        ("primary_range_nm", s.primary_range_nm),
    ] {
        if !(lo < hi) || lo < grid.min_nm() - 1e-9 || hi > grid.max_nm() + 1e-9 {
            return bad(
                name,
                format!(
                    "{lo}–{hi} nm must be increasing and inside the observer grid {}–{} nm",
                    grid.min_nm(),
                    grid.max_nm()
                ),
            );
        }
    }
    // K stratified bands of the primary range: a separation of at most one band's width is
    // drawn within the attempts of `stratified_primaries` for every K up to `max_primaries`.
    let band_nm = (s.primary_range_nm.1 - s.primary_range_nm.0) / s.max_primaries as f64;
    if s.min_primary_separation_nm > band_nm {
        return bad(
            "min_primary_separation_nm",
            format!(
                "{} nm is wider than one of {} bands of primary_range_nm ({band_nm:.3} nm): \
                 {} primaries could not be drawn that far apart",
                s.min_primary_separation_nm, s.max_primaries, s.max_primaries
            ),
        );
    }
    Ok(())
}

/// Run CMF-SIM on `observer`.
pub fn run_cmf_sim(observer: &dyn Observer, settings: &CmfSimSettings) -> Result<CmfSimResult> {
    run_cmf_sim_with_progress(observer, settings, &mut |_| {})
}

/// Location pairs per test wavelength.
pub type WavelengthPairs = Vec<Vec<[[f64; 2]; 2]>>;

/// [`run_cmf_sim`] with a progress callback (called after every primary set).
pub fn run_cmf_sim_with_progress(
    observer: &dyn Observer,
    settings: &CmfSimSettings,
    progress: &mut dyn FnMut(&CmfSimProgress),
) -> Result<CmfSimResult> {
    run_cmf_sim_until(observer, settings, progress, &AtomicBool::new(false))
}

/// [`run_cmf_sim_with_progress`] that ends with [`ColorimetryError::Stopped`] once `stop` is
/// set (checked before every primary set, so within one set's shows).
pub fn run_cmf_sim_until(
    observer: &dyn Observer,
    settings: &CmfSimSettings,
    progress: &mut dyn FnMut(&CmfSimProgress),
    stop: &AtomicBool,
) -> Result<CmfSimResult> {
    // A failed K's candidates are converged best first: every solve is the one converging
    // every candidate takes, so only the shows differ (cmf_sim/candidates.rs).
    run(observer, settings, progress, stop, true)
}

/// [`run_cmf_sim_until`], with the candidates of a failed K converged best first
/// or (`bound_candidates = false`, the reference in tests) every candidate solved fully.
fn run(
    observer: &dyn Observer,
    settings: &CmfSimSettings,
    progress: &mut dyn FnMut(&CmfSimProgress),
    stop: &AtomicBool,
    bound_candidates: bool,
) -> Result<CmfSimResult> {
    validate_settings(settings, observer.grid())?;
    let start = Instant::now();
    let s = settings;
    let mut rng = rand::rngs::StdRng::seed_from_u64(s.seed);
    let tests =
        WavelengthGrid::linspace(s.test_range_nm.0, s.test_range_nm.1, s.n_test_wavelengths)?;
    let tests = tests.as_slice().to_vec();
    let nw = tests.len();
    let intensity = s.intensity.unwrap_or_else(|| observer.stimulus_intensity());
    let draw_pairs = |rng: &mut dyn RngCore| -> WavelengthPairs {
        (0..nw)
            .map(|_| {
                (0..s.location_pairs)
                    .map(|_| observer.location_pair(rng))
                    .collect()
            })
            .collect()
    };

    // 1. Base error and energy.
    let base_pairs = draw_pairs(&mut rng);
    let base_seed: u64 = rng.random();
    let base = base_errors(observer, &tests, intensity, base_pairs, base_seed);
    let max_energy = base.energy.iter().copied().fold(0.0, f64::max);
    let floor = s.base_error_floor_rel * max_energy;
    let threshold: Vec<f64> = base
        .error
        .iter()
        .map(|&b| s.pass_ratio * b.max(floor))
        .collect();
    let no_cc = base.error.iter().sum::<f64>() >= base.energy.iter().sum::<f64>();
    let mut curves = vec![energy_curve(&tests, &base.energy, &threshold)];

    // 2. K = 1, 2, … until a set passes, then on through `margins_through_k`.
    let search = Search {
        observer,
        settings: s,
        tests: &tests,
        intensity,
        base: &base,
        threshold: &threshold,
        stop,
        bound_candidates,
    };
    let mut order = WavelengthOrder::by_energy_ratio(&base.energy, &threshold);
    let mut front = front_end(observer, s, nw, intensity, &base);
    let (mut per_k, mut dimension) = (Vec::new(), 0);
    for k in (1..=s.max_primaries).take_while(|_| !no_cc) {
        let (summary, reported) = search.search_k(
            k,
            &mut rng,
            &mut order,
            front.as_mut(),
            &draw_pairs,
            progress,
        )?;
        curves.push(reported);
        if summary.passed && dimension == 0 {
            dimension = k;
        }
        per_k.push(summary);
        if dimension > 0 && k >= s.margins_through_k {
            break;
        }
    }
    let calls = 1 + per_k.iter().map(|k| k.observer_calls).sum::<usize>();
    let n_shows = nw * s.location_pairs * 3 + per_k.iter().map(|k| k.shows).sum::<usize>();
    Ok(CmfSimResult {
        dimension,
        verdict: verdict(no_cc, dimension, s),
        no_colour_constancy: no_cc,
        observer: observer.name(),
        settings: s.clone(),
        intensity,
        test_wavelengths_nm: tests,
        base_error: base.error,
        energy: base.energy,
        base_error_floor: floor,
        threshold,
        curves,
        per_k,
        observer_calls: calls,
        shows: n_shows,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The observer's front-end Jacobians with the base step's test percepts, when the settings
/// reuse the base pairs and ask for them and the observer has a front end.
fn front_end<'a>(
    observer: &dyn Observer,
    s: &CmfSimSettings,
    n_tests: usize,
    intensity: f64,
    base: &'a base::Base,
) -> Option<FrontEnd<'a>> {
    (s.reuse_base_pairs && s.front_end_jacobians)
        .then(|| FrontEndJacobians::new(observer, n_tests, intensity, s.solver.fd_step))
        .flatten()
        .map(|jacobians| FrontEnd {
            jacobians,
            test: TestPercepts {
                at_a: &base.at_a,
                at_b: &base.test_b,
            },
        })
}

/// The 0-primary curve: the percept energy against the thresholds.
fn energy_curve(tests: &[f64], energy: &[f64], threshold: &[f64]) -> ErrorCurve {
    ErrorCurve {
        n_primaries: 0,
        primaries_nm: vec![],
        alphas: vec![vec![]; tests.len()],
        area: trapezoid(tests, energy),
        worst_ratio: ratio(energy, threshold),
        passed: energy.iter().zip(threshold).all(|(e, t)| e < t),
        errors: energy.to_vec(),
        set_index: 0,
        fully_evaluated: true,
    }
}

fn verdict(no_cc: bool, dimension: usize, s: &CmfSimSettings) -> String {
    if no_cc {
        "no colour constancy: base errors exceed the percept energy; dimension undefined".into()
    } else if dimension == 0 {
        format!(
            "no primary set passed for K ≤ {} ({} sets per K); dimension undefined",
            s.max_primaries, s.sets_per_k
        )
    } else {
        format!("colour dimensionality {dimension}")
    }
}

/// The error curve of a fully evaluated set.
fn curve(
    k: usize,
    set: usize,
    prim: &[f64],
    tests: &[f64],
    threshold: &[f64],
    out: &SetOutcome,
) -> ErrorCurve {
    let errors: Vec<f64> = out.matches.iter().map(|m| m.error).collect();
    ErrorCurve {
        n_primaries: k,
        primaries_nm: prim.to_vec(),
        alphas: out.matches.iter().map(|m| m.alpha.clone()).collect(),
        area: trapezoid(tests, &errors),
        worst_ratio: ratio(&errors, threshold),
        passed: errors.iter().zip(threshold).all(|(e, t)| e < t),
        errors,
        set_index: set,
        fully_evaluated: out.fully_evaluated,
    }
}

fn ratio(errors: &[f64], threshold: &[f64]) -> f64 {
    errors
        .iter()
        .zip(threshold)
        .map(|(e, t)| e / t)
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests;
