//! Converging the candidates of a failed K, best first.
//!
//! A failed K reports the candidate (one of the `converged_sets` rejected sets with the lowest
//! ratios early rejection saw) with the lowest worst ratio `max error / threshold` once every
//! wavelength is solved to convergence, the first of equals in candidate order. Converging
//! them all costs a full evaluation each; most of it decides nothing, because a candidate
//! whose converged error at one wavelength already exceeds the best candidate's worst ratio
//! cannot be reported.
//!
//! Each candidate carries a **lower bound** on its converged worst ratio: the largest ratio
//! among its wavelengths solved to convergence so far. At first these are the wavelengths early
//! rejection solved without stopping below the threshold (its failing ones; a solve is
//! deterministic, so converging the set solves them again to the same error); a wavelength that
//! stopped below its threshold only bounds its converged error from above and does not count.
//!
//! **Best first.** The candidate with the lowest bound (the earlier in candidate order of equal
//! bounds) is solved one more round along the wavelength order — rounds of 1, 2, 4, … ×
//! `first_round_wavelengths` wavelengths — each wavelength to convergence from where early
//! rejection left it, exactly the solve a full evaluation takes
//! ([`super::sets::converge_wavelengths`]). When the candidate with the lowest bound is solved
//! at every wavelength, its bound is its converged worst ratio `r`, and every other candidate's
//! converged worst ratio is at least its bound, which is at least `r` (an earlier candidate's
//! bound strictly more). So it is the candidate converging every one of them reports, with the
//! same solves; the others are left unconverged (`sets_bounded_out`). A lone candidate (the
//! passing set of a K) is converged in one call.

use std::sync::atomic::Ordering;

use super::search::{Search, Tried};
use super::sets::{converge_wavelengths, FrontEnd, SetOutcome, WavelengthOrder};
use super::{curve, ErrorCurve, KSummary};
use crate::error::{ColorimetryError, Result};
use crate::matching::WavelengthMatch;

/// A candidate being converged in rounds.
struct Converging<'t> {
    tried: &'t Tried,
    /// Its wavelengths solved to convergence so far, in order of solving.
    solved: Vec<WavelengthMatch>,
    /// How many wavelengths of the order are solved.
    done: usize,
    /// The next round's size, in wavelengths.
    round: usize,
    /// The largest converged `error / threshold` so far: a lower bound on its worst ratio.
    bound: f64,
}

impl Search<'_> {
    /// The reported curve of the candidates `tried` (module docs), with the solves and shows
    /// spent added to `summary`.
    pub(super) fn converge_best_first(
        &self,
        k: usize,
        tried: &[Tried],
        order: &WavelengthOrder,
        summary: &mut KSummary,
        mut front: Option<&mut FrontEnd<'_>>,
    ) -> Result<ErrorCurve> {
        let n = self.tests.len();
        let lone = tried.len() == 1;
        let first_round = self.settings.first_round_wavelengths.max(1);
        let mut candidates: Vec<Converging<'_>> = tried
            .iter()
            .map(|t| self.start(t, first_round, n))
            .collect();
        let best = loop {
            if self.stop.load(Ordering::Relaxed) {
                return Err(ColorimetryError::Stopped);
            }
            let i = (0..candidates.len())
                .min_by(|&a, &b| {
                    let (ba, bb) = (candidates[a].bound, candidates[b].bound);
                    ba.total_cmp(&bb).then(a.cmp(&b))
                })
                .expect("at least one set per K");
            let c = &mut candidates[i];
            if c.done == n {
                break i;
            }
            let which = match lone {
                true => &order.as_slice()[c.done..],
                false => &order.as_slice()[c.done..(c.done + c.round).min(n)],
            };
            self.converge_round(c, which, front.as_deref_mut(), summary);
        };
        for c in &candidates {
            match c.done == n {
                true => summary.sets_fully_evaluated += 1,
                false => summary.sets_bounded_out += 1,
            }
        }
        let c = candidates.swap_remove(best);
        let mut matches = c.solved;
        matches.sort_by_key(|m| m.wavelength);
        // The calls and shows spent are in `summary`; the curve reads the matches only.
        let full = SetOutcome {
            matches,
            fully_evaluated: true,
            ..SetOutcome::default()
        }
        .judged(self.threshold);
        let t = c.tried;
        Ok(curve(
            k,
            t.index,
            &t.primaries,
            self.tests,
            self.threshold,
            &full,
        ))
    }

    /// A candidate before its first round: converged where early rejection solved it without
    /// stopping below the threshold (everywhere, when it was evaluated fully).
    fn start<'t>(&self, t: &'t Tried, first_round: usize, n: usize) -> Converging<'t> {
        let full = t.outcome.fully_evaluated;
        let bound = t
            .outcome
            .matches
            .iter()
            .filter(|m| full || !m.stopped_below)
            .map(|m| m.error / self.threshold[m.wavelength])
            .fold(0.0, f64::max);
        Converging {
            tried: t,
            solved: if full {
                t.outcome.matches.clone()
            } else {
                Vec::new()
            },
            done: if full { n } else { 0 },
            round: first_round,
            bound,
        }
    }

    /// Solve `which` of candidate `c` to convergence and raise its bound.
    fn converge_round(
        &self,
        c: &mut Converging<'_>,
        which: &[usize],
        front: Option<&mut FrontEnd<'_>>,
        summary: &mut KSummary,
    ) {
        let pb = self.problem(c.tried);
        let options = self.options(Some(&c.tried.outcome.matches));
        let solver = &self.settings.solver;
        let (matches, calls, shows) = converge_wavelengths(&pb, solver, which, &options, front);
        summary.wavelength_solves += matches.len();
        summary.observer_calls += calls;
        summary.shows += shows;
        summary.reported_curve_shows += shows;
        c.bound = matches
            .iter()
            .map(|m| m.error / self.threshold[m.wavelength])
            .fold(c.bound, f64::max);
        c.solved.extend(matches);
        c.done += which.len();
        c.round *= 2;
    }
}
