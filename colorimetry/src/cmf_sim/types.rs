//! The settings and results of CMF-SIM (see [`super`] for the algorithm).

use serde::{Deserialize, Serialize};

use crate::matching::SolverSettings;

/// CMF-SIM settings; defaults from the paper (S-04) and docs/references.md#cmf-sim-defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CmfSimSettings {
    /// Number of test wavelengths (paper: 100).
    pub n_test_wavelengths: usize,
    /// Test range, nm (paper: 400–700).
    pub test_range_nm: (f64, f64),
    /// Primary range split into K bands, nm (paper §5: monochromatic primaries in 400–700 nm;
    /// the K equal bands are chosen here, docs/references.md#cmf-sim-defaults).
    pub primary_range_nm: (f64, f64),
    /// Largest K tried.
    pub max_primaries: usize,
    /// Go on past the first K that passes, up to this K (at most `max_primaries`; 0, the
    /// default, stops at the first pass as the paper's search does). The dimension stays the
    /// first K that passes; a larger K's margin (its first passing set's worst ratio, as for
    /// any passing K) says how far inside the border a reading sits, e.g. the K3 margin of a
    /// run that reads 2 where a protocol's outcome is `log K3`. Set in a run's config it applies
    /// to the readings during training too.
    pub margins_through_k: usize,
    /// Primary sets drawn per K before K is declared failed (paper: 500).
    pub sets_per_k: usize,
    /// Location pairs averaged per error evaluation (docs/references.md#cmf-sim-defaults: about 8).
    pub location_pairs: usize,
    /// Judge every match at the location pairs its base error was measured at (common random
    /// numbers: the pass test `error < 1.5 × base` then compares like with like). `false`
    /// draws fresh pairs for every primary set, as the paper's pseudocode does; with few pairs
    /// that makes the ratio noisy for observers whose percept depends on location.
    pub reuse_base_pairs: bool,
    /// A set passes when every error < pass_ratio × base (paper Fig. 8: 150 %).
    pub pass_ratio: f64,
    /// Floor on the base error, as a fraction of the largest percept energy.
    pub base_error_floor_rel: f64,
    /// Reject a primary set at the first wavelength that fails (see [`super::sets`]); same verdicts
    /// as full evaluation, far fewer shows for failing sets.
    pub early_rejection: bool,
    /// Wavelengths in the first round of early rejection (later rounds double).
    pub first_round_wavelengths: usize,
    /// At a failed K, how many rejected sets (those with the lowest worst ratio over the
    /// wavelengths they were solved at) are then solved at every wavelength; the margin
    /// reported is the best of them (see the search in `cmf_sim/search.rs`).
    pub converged_sets: usize,
    /// With `reuse_base_pairs`, measure the α = 0 Jacobians once per location pair through the
    /// observer's linear front end, if it has one ([`crate::matching::FrontEndJacobians`]).
    pub front_end_jacobians: bool,
    /// Minimum spacing of two primaries, nm (docs/references.md#cmf-sim-defaults: 5).
    pub min_primary_separation_nm: f64,
    /// Test intensity; `None` = [`crate::observer::Observer::stimulus_intensity`].
    pub intensity: Option<f64>,
    /// α solver.
    pub solver: SolverSettings,
    /// RNG seed (locations, primaries, noise seeds).
    pub seed: u64,
}

impl Default for CmfSimSettings {
    fn default() -> Self {
        CmfSimSettings {
            n_test_wavelengths: 100,
            test_range_nm: (400.0, 700.0),
            primary_range_nm: (400.0, 700.0),
            max_primaries: 6,
            margins_through_k: 0,
            sets_per_k: 500,
            location_pairs: 8,
            reuse_base_pairs: true,
            pass_ratio: 1.5,
            base_error_floor_rel: 1e-8,
            early_rejection: true,
            first_round_wavelengths: 1,
            converged_sets: 5,
            front_end_jacobians: true,
            min_primary_separation_nm: 5.0,
            intensity: None,
            solver: SolverSettings::default(),
            seed: 0,
        }
    }
}

/// The error curve of one primary set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorCurve {
    /// K.
    pub n_primaries: usize,
    /// The primaries, nm.
    pub primaries_nm: Vec<f64>,
    /// α per test wavelength.
    pub alphas: Vec<Vec<f64>>,
    /// Matching error per test wavelength.
    pub errors: Vec<f64>,
    /// ∫ error dλ (trapezoid, nm).
    pub area: f64,
    /// `max_λ error / threshold` (< 1 means the set passes).
    pub worst_ratio: f64,
    /// Whether every wavelength passed.
    pub passed: bool,
    /// Which set at this K (1-based; 0 for the energy curve).
    pub set_index: usize,
    /// Every wavelength solved to convergence (true for every reported curve).
    pub fully_evaluated: bool,
}

/// One primary set tried.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetRecord {
    /// The primaries, nm.
    pub primaries_nm: Vec<f64>,
    /// Test wavelengths solved before the verdict (all of them unless rejected early).
    pub wavelengths_solved: usize,
    /// `max error / threshold` over the wavelengths solved.
    pub worst_ratio_solved: f64,
    /// Whether the set passed.
    pub passed: bool,
}

/// What happened at one K.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KSummary {
    /// K.
    pub n_primaries: usize,
    /// Sets tried (stops at the first passing set).
    pub sets_tried: usize,
    /// Whether a set passed.
    pub passed: bool,
    /// Sets rejected before every wavelength was solved.
    pub sets_rejected_early: usize,
    /// Wavelength solves, including the full solve of the reported curve.
    pub wavelength_solves: usize,
    /// Batched observer calls.
    pub observer_calls: usize,
    /// Shows evaluated.
    pub shows: usize,
    /// Of these, the shows that completed the reported curve (solving at every wavelength the
    /// set that was rejected early or stopped below the thresholds).
    pub reported_curve_shows: usize,
    /// Wall time, s.
    pub seconds: f64,
    /// Sets solved at every wavelength to convergence (the passing set, or the best rejected
    /// sets of a failed K).
    pub sets_fully_evaluated: usize,
    /// Candidates of a failed K left unconverged: their converged errors so far already
    /// reached the reported candidate's worst ratio, so they cannot be the reported set
    /// (converged best first: `cmf_sim/candidates.rs`).
    #[serde(default)]
    pub sets_bounded_out: usize,
    /// The reported set's `max error / threshold` over every test wavelength, after
    /// convergence (< 1: the set passes).
    pub converged_worst_ratio: f64,
    /// Test wavelengths at which the reported set fails (error ≥ threshold).
    pub failing_wavelengths: usize,
    /// Where the reported set's ratio is worst, nm.
    pub worst_wavelength_nm: f64,
    /// Every set tried, in order.
    pub sets: Vec<SetRecord>,
}

impl KSummary {
    /// An empty summary for `k` primaries.
    pub fn new(k: usize) -> Self {
        KSummary {
            n_primaries: k,
            sets_tried: 0,
            passed: false,
            sets_rejected_early: 0,
            wavelength_solves: 0,
            observer_calls: 0,
            shows: 0,
            reported_curve_shows: 0,
            seconds: 0.0,
            sets_fully_evaluated: 0,
            sets_bounded_out: 0,
            converged_worst_ratio: f64::INFINITY,
            failing_wavelengths: 0,
            worst_wavelength_nm: f64::NAN,
            sets: Vec::new(),
        }
    }

    /// Add the solves, calls and shows of one evaluation.
    pub fn account(&mut self, out: &super::sets::SetOutcome) {
        self.wavelength_solves += out.matches.len();
        self.observer_calls += out.observer_calls;
        self.shows += out.shows;
    }

    /// Take the margin of the reported (converged) curve.
    pub fn set_margin(&mut self, reported: &ErrorCurve, tests_nm: &[f64], threshold: &[f64]) {
        let ratios: Vec<f64> = reported
            .errors
            .iter()
            .zip(threshold)
            .map(|(e, t)| e / t)
            .collect();
        self.converged_worst_ratio = reported.worst_ratio;
        self.failing_wavelengths = ratios.iter().filter(|r| !(**r < 1.0)).count();
        self.worst_wavelength_nm = ratios
            .iter()
            .zip(tests_nm)
            .max_by(|a, b| a.0.total_cmp(b.0))
            .map_or(f64::NAN, |(_, &w)| w);
    }

    /// The smallest worst ratio over the wavelengths each set was solved at: a lower bound on
    /// the converged margin of a failed K (early rejection stops at the first failure).
    pub fn lower_bound_ratio(&self) -> Option<f64> {
        self.sets
            .iter()
            .map(|s| s.worst_ratio_solved)
            .min_by(f64::total_cmp)
    }

    /// What this K found, in words, e.g. "K = 2: all 100 sets fail; the best of 5 solved at
    /// every wavelength fails at 23 of 100 wavelengths, worst 4.90× the threshold (452 nm)".
    pub fn describe(&self, n_wavelengths: usize) -> String {
        let k = self.n_primaries;
        if self.passed {
            format!(
                "K = {k}: set {} of {} tried passes at every wavelength; its worst error is {:.2}× the threshold ({:.0} nm)",
                self.sets_tried,
                self.sets_tried,
                self.converged_worst_ratio,
                self.worst_wavelength_nm
            )
        } else {
            format!(
                "K = {k}: all {} sets fail; the best of {} solved at every wavelength fails at {} of {n_wavelengths} wavelengths, worst {:.2}× the threshold ({:.0} nm)",
                self.sets_tried,
                self.sets_fully_evaluated,
                self.failing_wavelengths,
                self.converged_worst_ratio,
                self.worst_wavelength_nm
            )
        }
    }
}

/// The result of CMF-SIM.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CmfSimResult {
    /// Colour dimensionality; 0 when undefined (no colour constancy) or no K ≤ max passed.
    pub dimension: usize,
    /// Human-readable verdict.
    pub verdict: String,
    /// True when the base errors exceed the percept energy (paper S-05 baseline 1).
    pub no_colour_constancy: bool,
    /// Observer description.
    pub observer: String,
    /// The settings used.
    pub settings: CmfSimSettings,
    /// Test intensity used.
    pub intensity: f64,
    /// Test wavelengths, nm.
    pub test_wavelengths_nm: Vec<f64>,
    /// Base error per wavelength.
    pub base_error: Vec<f64>,
    /// Percept energy per wavelength (the 0-primary error).
    pub energy: Vec<f64>,
    /// The absolute base-error floor used.
    pub base_error_floor: f64,
    /// Pass threshold per wavelength.
    pub threshold: Vec<f64>,
    /// One curve per K = 0, 1, … (K = 0 is the energy): the passing set, or at a failed K the
    /// set with the lowest worst ratio (over the wavelengths solved, under early rejection).
    pub curves: Vec<ErrorCurve>,
    /// Per-K summary.
    pub per_k: Vec<KSummary>,
    /// Observer calls and single shows evaluated.
    pub observer_calls: usize,
    /// Shows evaluated.
    pub shows: usize,
    /// Wall time, s.
    pub seconds: f64,
}

/// Progress report passed to the callback after each primary set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CmfSimProgress {
    /// Current K.
    pub n_primaries: usize,
    /// Sets tried so far at this K.
    pub sets_tried: usize,
    /// The budget per K.
    pub sets_per_k: usize,
    /// Lowest worst-ratio so far at this K (over the wavelengths solved).
    pub best_worst_ratio: f64,
    /// Wavelengths the last set was solved at.
    pub wavelengths_solved: usize,
}
