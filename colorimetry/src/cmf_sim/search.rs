//! Step 2 of CMF-SIM for one K: draw primary sets until one passes or the budget is spent, then
//! solve the reported sets at every wavelength to convergence.
//!
//! **Converged margins.** Early rejection ([`super::sets`]) stops a set at its first failing
//! wavelength, so the worst ratio it saw is a *lower bound* on the set's true worst ratio. For a
//! failed K the `converged_sets` rejected sets with the lowest lower bounds are therefore solved
//! at every wavelength, continuing where they stopped; the reported curve and margin are the best
//! of those by their converged worst ratio. For a passing K the passing set is solved at every
//! wavelength (it may have stopped below the threshold at the first sub-threshold iterate).
//!
//! **Bounded candidates.** Only the best candidate's curve is reported, so the candidates are
//! converged best first and a candidate is left unconverged once it cannot be the best
//! ([`super::candidates`]). The reported curve, margin and verdict are those of converging
//! every candidate, solve for solve (tested on analytic observers, and on one whose solves have
//! several minima); only the shows differ.

use rand::{Rng, RngCore};

use super::base::Base;
use super::sets::{evaluate_early, evaluate_fully, FrontEnd, SetOutcome, WavelengthOrder};
use super::{curve, stratified_primaries, CmfSimProgress, CmfSimSettings, ErrorCurve, KSummary};
use super::{SetRecord, WavelengthPairs};
use crate::error::{ColorimetryError, Result};
use crate::matching::{KnownAtZero, MatchOptions, MatchProblem};
use crate::observer::Observer;
use std::sync::atomic::{AtomicBool, Ordering};

/// What every K's search shares: the observer, the settings and step 1's results.
pub(super) struct Search<'a> {
    pub observer: &'a dyn Observer,
    pub settings: &'a CmfSimSettings,
    pub tests: &'a [f64],
    pub intensity: f64,
    pub base: &'a Base,
    pub threshold: &'a [f64],
    /// Set by the caller to stop the search (checked before every primary set).
    pub stop: &'a AtomicBool,
    /// Whether the candidates of a failed K are converged best first and bounded (module
    /// docs); `false` solves every candidate fully (the reference the bound is tested against).
    pub bound_candidates: bool,
}

/// A set tried: its primaries, locations and seed, and what its evaluation found.
pub(super) struct Tried {
    pub index: usize,
    pub primaries: Vec<f64>,
    fresh_pairs: Option<WavelengthPairs>,
    seed: u64,
    pub outcome: SetOutcome,
}

impl Search<'_> {
    pub(super) fn problem<'b>(&'b self, t: &'b Tried) -> MatchProblem<'b> {
        MatchProblem {
            observer: self.observer,
            test_wavelengths_nm: self.tests,
            primaries_nm: &t.primaries,
            intensity: self.intensity,
            pairs: t.fresh_pairs.as_ref().unwrap_or(&self.base.pairs),
            seed: t.seed,
        }
    }

    pub(super) fn options<'b>(
        &'b self,
        resume: Option<&'b [crate::matching::WavelengthMatch]>,
    ) -> MatchOptions<'b> {
        MatchOptions {
            stop_below: None,
            known_at_zero: self.settings.reuse_base_pairs.then_some(KnownAtZero {
                side_a: &self.base.at_a,
                side_b: &self.base.black_b,
            }),
            resume,
            front_end: None,
        }
    }

    /// Draw and evaluate one set.
    fn try_set(
        &self,
        k: usize,
        index: usize,
        rng: &mut dyn RngCore,
        order: &WavelengthOrder,
        front: Option<&mut FrontEnd<'_>>,
        draw_pairs: &dyn Fn(&mut dyn RngCore) -> WavelengthPairs,
    ) -> Result<Tried> {
        let s = self.settings;
        let primaries =
            stratified_primaries(k, s.primary_range_nm, s.min_primary_separation_nm, rng)?;
        let fresh_pairs = (!s.reuse_base_pairs).then(|| draw_pairs(rng));
        let fresh_seed: u64 = rng.random();
        let mut tried = Tried {
            index,
            primaries,
            fresh_pairs,
            seed: if s.reuse_base_pairs {
                self.base.seed
            } else {
                fresh_seed
            },
            outcome: SetOutcome::default(),
        };
        let pb = self.problem(&tried);
        let options = self.options(None);
        tried.outcome = if s.early_rejection {
            evaluate_early(
                &pb,
                &s.solver,
                self.threshold,
                &options,
                order,
                s.first_round_wavelengths,
                front,
            )
        } else {
            evaluate_fully(&pb, &s.solver, self.threshold, &options, front)
        };
        Ok(tried)
    }

    /// Solve `t` at every wavelength to convergence (continuing its earlier solves).
    fn converge(&self, t: &Tried, front: Option<&mut FrontEnd<'_>>) -> SetOutcome {
        if t.outcome.fully_evaluated {
            return t.outcome.clone();
        }
        let pb = self.problem(t);
        let options = self.options(Some(&t.outcome.matches));
        evaluate_fully(&pb, &self.settings.solver, self.threshold, &options, front)
    }

    /// Converge the candidates `tried` (in order): best first when bounded
    /// ([`super::candidates`]), else every one. The best curve by converged worst ratio, the
    /// first of equals.
    fn report(
        &self,
        k: usize,
        tried: &[Tried],
        order: &WavelengthOrder,
        summary: &mut KSummary,
        mut front: Option<&mut FrontEnd<'_>>,
    ) -> Result<ErrorCurve> {
        if self.bound_candidates {
            return self.converge_best_first(k, tried, order, summary, front);
        }
        let mut reported: Option<ErrorCurve> = None;
        for t in tried {
            if self.stop.load(Ordering::Relaxed) {
                return Err(ColorimetryError::Stopped);
            }
            let full = self.converge(t, front.as_deref_mut());
            if !t.outcome.fully_evaluated {
                summary.reported_curve_shows += full.shows;
                summary.account(&full);
            }
            summary.sets_fully_evaluated += 1;
            let c = curve(k, t.index, &t.primaries, self.tests, self.threshold, &full);
            if reported
                .as_ref()
                .is_none_or(|r| c.worst_ratio < r.worst_ratio)
            {
                reported = Some(c);
            }
        }
        Ok(reported.expect("at least one set per K"))
    }

    /// Step 2 for `k` primaries: the summary and the reported (converged) curve.
    pub fn search_k(
        &self,
        k: usize,
        rng: &mut dyn RngCore,
        order: &mut WavelengthOrder,
        mut front: Option<&mut FrontEnd<'_>>,
        draw_pairs: &dyn Fn(&mut dyn RngCore) -> WavelengthPairs,
        progress: &mut dyn FnMut(&CmfSimProgress),
    ) -> Result<(KSummary, ErrorCurve)> {
        let t0 = std::time::Instant::now();
        let mut summary = KSummary::new(k);
        let mut tried: Vec<Tried> = Vec::new();
        let mut best_bound = f64::INFINITY;
        for index in 1..=self.settings.sets_per_k {
            if self.stop.load(Ordering::Relaxed) {
                return Err(ColorimetryError::Stopped);
            }
            let t = self.try_set(k, index, rng, order, front.as_deref_mut(), draw_pairs)?;
            summary.account(&t.outcome);
            let bound = t.outcome.worst_ratio(self.threshold);
            best_bound = best_bound.min(bound);
            summary.sets_tried = index;
            summary.sets_rejected_early += usize::from(t.outcome.matches.len() < self.tests.len());
            summary.sets.push(SetRecord {
                primaries_nm: t.primaries.clone(),
                wavelengths_solved: t.outcome.matches.len(),
                worst_ratio_solved: bound,
                passed: t.outcome.passed,
            });
            order.move_to_front(&t.outcome.failed);
            progress(&CmfSimProgress {
                n_primaries: k,
                sets_tried: index,
                sets_per_k: self.settings.sets_per_k,
                best_worst_ratio: best_bound,
                wavelengths_solved: t.outcome.matches.len(),
            });
            summary.passed = t.outcome.passed;
            tried.push(t);
            if summary.passed {
                break;
            }
        }
        // The sets to converge: the passing one, or the best lower bounds of a failed K.
        if summary.passed {
            tried.drain(..tried.len() - 1);
        } else {
            tried.sort_by(|a, b| {
                a.outcome
                    .worst_ratio(self.threshold)
                    .total_cmp(&b.outcome.worst_ratio(self.threshold))
            });
            tried.truncate(self.settings.converged_sets.max(1));
        }
        let reported = self.report(k, &tried, order, &mut summary, front)?;
        summary.set_margin(&reported, self.tests, self.threshold);
        summary.seconds = t0.elapsed().as_secs_f64();
        Ok((summary, reported))
    }
}
