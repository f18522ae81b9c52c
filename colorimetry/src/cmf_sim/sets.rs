//! Evaluating one primary set in CMF-SIM: fully (every test wavelength solved to convergence) or
//! with early rejection.
//!
//! **Early rejection.** A set fails as soon as one test wavelength's converged error reaches its
//! threshold, so the wavelengths are solved in rounds of 1, 2, 4, … (in [`WavelengthOrder`]) and
//! the set is rejected after the first round with a failure. Inside a round a wavelength stops as
//! soon as its error is below its threshold ([`MatchOptions::stop_below`]): the pass test only
//! needs a match below it to exist. Both shortcuts leave every verdict unchanged — the solver's
//! path for a wavelength does not depend on which other wavelengths share its batch, and an
//! accepted LM step never raises the error — so the set passes or fails exactly as under full
//! evaluation (tested on the analytic observers). Only the reported curves (the passing set, and
//! the best rejected set per failed K) are then solved fully at every wavelength.
//!
//! **Order.** Wavelengths start in decreasing order of `energy / threshold` (hardest to match
//! with nothing) and every rejecting wavelength moves to the front (move-to-front), so later sets
//! are tested first where earlier sets failed.

use crate::matching::{
    solve_wavelengths, FrontEndJacobians, MatchOptions, MatchProblem, SolverSettings, TestPercepts,
    WavelengthMatch,
};

/// The front-end model ([`FrontEndJacobians`]) and the base percepts it is measured against.
pub struct FrontEnd<'a> {
    /// Models measured so far.
    pub jacobians: FrontEndJacobians,
    /// The base step's test-light percepts.
    pub test: TestPercepts<'a>,
}

/// The order in which early rejection visits the test wavelengths.
#[derive(Debug, Clone, PartialEq)]
pub struct WavelengthOrder {
    order: Vec<usize>,
}

impl WavelengthOrder {
    /// Decreasing `energy / threshold`.
    pub fn by_energy_ratio(energy: &[f64], threshold: &[f64]) -> Self {
        let mut order: Vec<usize> = (0..energy.len()).collect();
        let ratio = |w: usize| energy[w] / threshold[w];
        order.sort_by(|&a, &b| ratio(b).total_cmp(&ratio(a)).then(a.cmp(&b)));
        WavelengthOrder { order }
    }

    /// The wavelength indices in order.
    pub fn as_slice(&self) -> &[usize] {
        &self.order
    }

    /// Move `failed` (in the given order) to the front.
    pub fn move_to_front(&mut self, failed: &[usize]) {
        self.order.retain(|w| !failed.contains(w));
        let mut front = failed.to_vec();
        front.extend_from_slice(&self.order);
        self.order = front;
    }
}

/// The outcome of one set.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SetOutcome {
    /// Whether every wavelength matched below its threshold.
    pub passed: bool,
    /// The matches that were solved (all wavelengths, or up to the rejecting round), by
    /// wavelength index order of solving.
    pub matches: Vec<WavelengthMatch>,
    /// Whether every wavelength was solved to convergence (no early stop of any kind).
    pub fully_evaluated: bool,
    /// Wavelengths whose error reached the threshold, worst ratio first.
    pub failed: Vec<usize>,
    /// Observer calls and shows spent.
    pub observer_calls: usize,
    /// Shows evaluated.
    pub shows: usize,
}

impl SetOutcome {
    /// The same solves judged against `threshold`.
    pub fn judged(self, threshold: &[f64]) -> SetOutcome {
        let (fully, calls, shows) = (self.fully_evaluated, self.observer_calls, self.shows);
        outcome(self.matches, threshold, fully, calls, shows)
    }

    /// `max error / threshold` over the solved wavelengths.
    pub fn worst_ratio(&self, threshold: &[f64]) -> f64 {
        self.matches
            .iter()
            .map(|m| m.error / threshold[m.wavelength])
            .fold(0.0, f64::max)
    }
}

fn outcome(
    matches: Vec<WavelengthMatch>,
    threshold: &[f64],
    fully: bool,
    calls: usize,
    shows: usize,
) -> SetOutcome {
    let mut failed: Vec<(usize, f64)> = matches
        .iter()
        .filter(|m| !(m.error < threshold[m.wavelength]))
        .map(|m| (m.wavelength, m.error / threshold[m.wavelength]))
        .collect();
    failed.sort_by(|a, b| b.1.total_cmp(&a.1));
    SetOutcome {
        passed: failed.is_empty(),
        failed: failed.into_iter().map(|f| f.0).collect(),
        matches,
        fully_evaluated: fully,
        observer_calls: calls,
        shows,
    }
}

/// Bytes one wavelength's solve holds while it runs with `k` primaries over `pairs` location
/// pairs, each side read as `readout_len` f64: its Levenberg–Marquardt state (`5 + 2K`
/// readouts a pair: both sides at α and at the trial, the two Jacobians, the model's offset)
/// and the Jacobian pass's `2K` shows a pair with their readouts (a show, its index entry and
/// its heap line: about 128 bytes).
pub fn solve_bytes_per_wavelength(k: usize, pairs: usize, readout_len: usize) -> usize {
    let readouts = 5 + 2 * k + 2 * k;
    pairs * (readouts * readout_len * 8 + 2 * k * 128)
}

/// The most bytes the wavelengths solved together may hold ([`solve_bytes_per_wavelength`]
/// each): a large reading (thousands of location pairs) is solved in groups under it, so the
/// search's memory stops growing with K once one K's solves fill it.
pub const SOLVE_GROUP_BYTES: usize = 256 << 20;

/// How many wavelengths are solved together: as many as fit in [`SOLVE_GROUP_BYTES`], at least
/// one. A wavelength's solve does not depend on which others share its batch, so the grouping
/// changes no result, only the observer calls.
pub fn wavelengths_per_group(k: usize, pairs: usize, readout_len: usize) -> usize {
    (SOLVE_GROUP_BYTES / solve_bytes_per_wavelength(k, pairs, readout_len).max(1)).max(1)
}

/// Solve `which` with `options` in groups ([`wavelengths_per_group`]), measuring the
/// front-end Jacobians each group lacks first. The matches in the order of `which`.
fn solve(
    pb: &MatchProblem<'_>,
    solver: &SolverSettings,
    which: &[usize],
    options: &MatchOptions<'_>,
    front: &mut Option<&mut FrontEnd<'_>>,
) -> (Vec<WavelengthMatch>, usize, usize) {
    let pairs = which.iter().map(|&w| pb.pairs[w].len()).max().unwrap_or(0);
    let k = pb.primaries_nm.len();
    let group = wavelengths_per_group(k, pairs, pb.observer.percept_dim());
    solve_in_groups(pb, solver, which, options, front, group)
}

/// [`solve`] with `group` wavelengths solved together.
fn solve_in_groups(
    pb: &MatchProblem<'_>,
    solver: &SolverSettings,
    which: &[usize],
    options: &MatchOptions<'_>,
    front: &mut Option<&mut FrontEnd<'_>>,
    group: usize,
) -> (Vec<WavelengthMatch>, usize, usize) {
    let (mut matches, mut calls, mut shows) = (Vec::with_capacity(which.len()), 0, 0);
    for part in which.chunks(group.max(1)) {
        if let Some(f) = front.as_deref_mut() {
            let n = f.jacobians.measure(pb, part, f.test);
            calls += usize::from(n > 0);
            shows += n;
        }
        let opts = MatchOptions {
            front_end: front.as_deref().map(|f| &f.jacobians),
            ..*options
        };
        let r = solve_wavelengths(pb, solver, part, &opts);
        matches.extend(r.matches);
        calls += r.observer_calls;
        shows += r.shows;
    }
    (matches, calls, shows)
}

/// Solve every wavelength to convergence.
pub fn evaluate_fully(
    pb: &MatchProblem<'_>,
    solver: &SolverSettings,
    threshold: &[f64],
    options: &MatchOptions<'_>,
    mut front: Option<&mut FrontEnd<'_>>,
) -> SetOutcome {
    let all: Vec<usize> = (0..pb.test_wavelengths_nm.len()).collect();
    let full = MatchOptions {
        stop_below: None,
        ..*options
    };
    let (mut matches, calls, shows) = solve(pb, solver, &all, &full, &mut front);
    matches.sort_by_key(|m| m.wavelength);
    outcome(matches, threshold, true, calls, shows)
}

/// Solve in rounds of `first_round`, 2·`first_round`, … wavelengths along `order`, each
/// wavelength stopping below its threshold; stop after the first round with a failure.
pub fn evaluate_early(
    pb: &MatchProblem<'_>,
    solver: &SolverSettings,
    threshold: &[f64],
    options: &MatchOptions<'_>,
    order: &WavelengthOrder,
    first_round: usize,
    front: Option<&mut FrontEnd<'_>>,
) -> SetOutcome {
    let opts = MatchOptions {
        stop_below: Some(threshold),
        ..*options
    };
    let (matches, calls, shows) =
        in_rounds(pb, solver, threshold, &opts, order, first_round, front);
    outcome(matches, threshold, false, calls, shows)
}

/// Solve `which` to convergence (never stopped below a threshold), each wavelength exactly as
/// [`evaluate_fully`] with the same `options` solves it: its matches in the order of `which`,
/// the observer calls and the shows.
pub fn converge_wavelengths(
    pb: &MatchProblem<'_>,
    solver: &SolverSettings,
    which: &[usize],
    options: &MatchOptions<'_>,
    mut front: Option<&mut FrontEnd<'_>>,
) -> (Vec<WavelengthMatch>, usize, usize) {
    let opts = MatchOptions {
        stop_below: None,
        ..*options
    };
    solve(pb, solver, which, &opts, &mut front)
}

/// Solve along `order` in rounds of 1, 2, 4, … × `first_round` with `opts`; stop after the
/// first round in which some error reaches `threshold`. The matches in order of solving, the
/// observer calls and the shows.
fn in_rounds(
    pb: &MatchProblem<'_>,
    solver: &SolverSettings,
    threshold: &[f64],
    opts: &MatchOptions<'_>,
    order: &WavelengthOrder,
    first_round: usize,
    mut front: Option<&mut FrontEnd<'_>>,
) -> (Vec<WavelengthMatch>, usize, usize) {
    let order = order.as_slice();
    let (mut matches, mut calls, mut shows) = (Vec::new(), 0, 0);
    let (mut done, mut size) = (0, first_round.max(1));
    while done < order.len() {
        let round = &order[done..(done + size).min(order.len())];
        let (r, c, n) = solve(pb, solver, round, opts, &mut front);
        calls += c;
        shows += n;
        let failed = r.iter().any(|m| !(m.error < threshold[m.wavelength]));
        matches.extend(r);
        done += round.len();
        size *= 2;
        if failed {
            break;
        }
    }
    (matches, calls, shows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::{ConeObserver, NakaRushtonObserver};
    use crate::cones::{ConeClass, ConeTemplate};
    use crate::grid::WavelengthGrid;
    use crate::matching::tests::{problem, problem_pairs, WithFrontEnd};
    use crate::observer::{percept_of, Stimulus};

    /// Solve `which` of `pb` in groups of `group` with a fresh front-end model, stopping below
    /// `stop`, then continue every solve to convergence in groups of `group`.
    fn grouped(
        pb: &MatchProblem<'_>,
        test: TestPercepts<'_>,
        which: &[usize],
        stop: &[f64],
        group: usize,
    ) -> [(Vec<WavelengthMatch>, usize); 2] {
        let s = SolverSettings::default();
        let jacobians = FrontEndJacobians::new(pb.observer, which.len(), 1.0, s.fd_step).unwrap();
        let mut front = FrontEnd { jacobians, test };
        let early = MatchOptions {
            stop_below: Some(stop),
            ..MatchOptions::default()
        };
        let (a, _, shows_a) = solve_in_groups(pb, &s, which, &early, &mut Some(&mut front), group);
        let resume = MatchOptions {
            resume: Some(&a),
            ..MatchOptions::default()
        };
        let (b, _, shows_b) = solve_in_groups(pb, &s, which, &resume, &mut Some(&mut front), group);
        [(a, shows_a), (b, shows_b)]
    }

    #[test]
    fn solving_in_groups_changes_no_match_and_no_show() {
        let cones = ConeObserver::new(
            &ConeClass::lms(),
            &ConeTemplate::default(),
            &WavelengthGrid::default(),
        )
        .unwrap();
        let o = WithFrontEnd::new(NakaRushtonObserver::new(cones.clone(), 0.5), &cones);
        let tests: Vec<f64> = (0..7).map(|i| 420.0 + 40.0 * i as f64).collect();
        let prim = [455.0, 530.0, 610.0];
        let pairs = problem_pairs(tests.len(), 3);
        let pb = problem(&o, &tests, &prim, &pairs, 11);
        let (mut at_a, mut at_b) = (Vec::new(), Vec::new());
        for (w, &t) in tests.iter().enumerate() {
            for &[a, b] in &pairs[w] {
                at_a.extend(percept_of(&o, Stimulus::monochromatic(t, 1.0), a));
                at_b.extend(percept_of(&o, Stimulus::monochromatic(t, 1.0), b));
            }
        }
        let test = TestPercepts {
            at_a: &at_a,
            at_b: &at_b,
        };
        // every solve stops below a hundredth of its energy first, then is continued
        let energy = percept_of(&o, Stimulus::monochromatic(500.0, 1.0), [0.0; 2]);
        let stop = vec![1e-2 * energy.iter().map(|v| v * v).sum::<f64>(); tests.len()];
        let which = [3, 0, 6, 1, 5, 2, 4];
        let together = grouped(&pb, test, &which, &stop, which.len());
        assert!(together[0].0.iter().any(|m| m.stopped_below));
        for group in [1, 2, 3] {
            let parts = grouped(&pb, test, &which, &stop, group);
            for (p, t) in parts.iter().zip(&together) {
                assert_eq!(
                    p.0, t.0,
                    "groups of {group}: the same matches, in the same order"
                );
                assert_eq!(p.1, t.1, "groups of {group}: the same shows");
            }
        }
        assert_eq!(
            together[1]
                .0
                .iter()
                .map(|m| m.wavelength)
                .collect::<Vec<_>>(),
            which
        );
    }

    #[test]
    fn a_large_reading_is_solved_in_groups_that_fit_the_budget() {
        // 100 wavelengths, 4 096 pairs, K = 4, 3 channels × 64 samples: one group does not fit
        let (k, pairs, readout) = (4, 4096, 192);
        let group = wavelengths_per_group(k, pairs, readout);
        assert!(group < 100, "{group}");
        assert!(group * solve_bytes_per_wavelength(k, pairs, readout) <= SOLVE_GROUP_BYTES);
        assert!((group + 1) * solve_bytes_per_wavelength(k, pairs, readout) > SOLVE_GROUP_BYTES);
        // the quick eye's defaults (8 pairs) solve every wavelength at once
        assert!(wavelengths_per_group(4, 8, 192) >= 100);
        // one wavelength larger than the budget is still solved, alone
        assert_eq!(wavelengths_per_group(8, 1 << 20, 4096), 1);
    }
}
