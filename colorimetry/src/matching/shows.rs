//! The shows of the matching solver: the two sides' stimuli for given α, their batched
//! observer calls, and the passes of one iteration (E(0), the Jacobian's differences, the
//! trial steps) over every wavelength being solved.

use super::*;

/// Side A: the test light plus `−α_i` of every primary with α_i < 0, plus `h` of primary
/// `extra` (a finite-difference show).
fn side_a(
    test_nm: f64,
    prim: &[f64],
    alpha: &[f64],
    i0: f64,
    extra: Option<usize>,
    h: f64,
) -> Stimulus {
    let mut lines = vec![(test_nm, i0)];
    for (i, (&p, &a)) in prim.iter().zip(alpha).enumerate() {
        let amount = (-a).max(0.0) + if extra == Some(i) { h } else { 0.0 };
        if amount > 0.0 {
            lines.push((p, amount * i0));
        }
    }
    Stimulus::Lines(lines)
}

/// Side B: `α_i` of every primary with α_i > 0, plus `h` of primary `extra`.
fn side_b(prim: &[f64], alpha: &[f64], i0: f64, extra: Option<usize>, h: f64) -> Stimulus {
    let mut lines = Vec::with_capacity(prim.len());
    for (i, (&p, &a)) in prim.iter().zip(alpha).enumerate() {
        let amount = a.max(0.0) + if extra == Some(i) { h } else { 0.0 };
        if amount > 0.0 {
            lines.push((p, amount * i0));
        }
    }
    Stimulus::Lines(lines)
}

/// The shows of one batched call and the running call/show counts.
pub(super) struct Batch<'p, 'a> {
    pb: &'p MatchProblem<'a>,
    /// Finite-difference step (units of I).
    h: f64,
    shows: Vec<Show>,
    out: Vec<f64>,
    pub(super) calls: usize,
    pub(super) total: usize,
}

impl<'p, 'a> Batch<'p, 'a> {
    pub(super) fn new(pb: &'p MatchProblem<'a>, h: f64) -> Self {
        Batch {
            pb,
            h,
            shows: Vec::new(),
            out: Vec::new(),
            calls: 0,
            total: 0,
        }
    }

    /// Queue side A (`on_b = false`) or B of wavelength `w`, pair `p` at `alpha` (+ `h` of
    /// primary `extra`); returns the show's index.
    fn push(
        &mut self,
        w: usize,
        p: usize,
        on_b: bool,
        alpha: &[f64],
        extra: Option<usize>,
    ) -> usize {
        let pb = self.pb;
        let h = self.h;
        let [loc_a, loc_b] = pb.pairs[w][p];
        let (stimulus, location, side) = if on_b {
            (
                side_b(pb.primaries_nm, alpha, pb.intensity, extra, h),
                loc_b,
                2,
            )
        } else {
            let t = pb.test_wavelengths_nm[w];
            (
                side_a(t, pb.primaries_nm, alpha, pb.intensity, extra, h),
                loc_a,
                1,
            )
        };
        self.shows.push(Show {
            stimulus,
            location,
            noise_seed: show_seed(pb.seed, w, p, side),
        });
        self.shows.len() - 1
    }

    /// Evaluate the queued shows (if any).
    fn run(&mut self) {
        if self.shows.is_empty() {
            return;
        }
        let n = self.pb.observer.percept_dim();
        self.out.clear();
        self.out.resize(self.shows.len() * n, 0.0);
        self.pb.observer.percepts(&self.shows, &mut self.out);
        self.calls += 1;
        self.total += self.shows.len();
    }

    fn percept(&self, s: usize) -> &[f64] {
        let n = self.pb.observer.percept_dim();
        &self.out[s * n..(s + 1) * n]
    }

    fn clear(&mut self) {
        self.shows.clear();
    }
}

/// E(0) of every state: resumed from an earlier report, copied from the known percepts, or
/// shown to the observer in one call.
pub(super) fn initial_percepts(
    pb: &MatchProblem<'_>,
    options: &MatchOptions<'_>,
    batch: &mut Batch<'_, '_>,
    states: &mut [State],
) {
    let n = pb.observer.percept_dim();
    let mut pending: Vec<(usize, usize, usize, usize)> = Vec::new(); // (state, pair, show A, show B)
    for (si, s) in states.iter_mut().enumerate() {
        let np = pb.pairs[s.w].len();
        let earlier = options
            .resume
            .and_then(|r| r.iter().find(|m| m.wavelength == s.w && m.resume.is_some()));
        if let Some(m) = earlier {
            s.resume(m);
            continue;
        }
        match options.known_at_zero {
            Some(known) => {
                let start = known_offset(pb, s.w) * n;
                let len = np * n;
                assert!(
                    known.side_a.len() >= start + len && known.side_b.len() >= start + len,
                    "solve_wavelengths: known percepts hold {} / {} values, need {}",
                    known.side_a.len(),
                    known.side_b.len(),
                    start + len
                );
                s.pa.copy_from_slice(&known.side_a[start..start + len]);
                s.pb.copy_from_slice(&known.side_b[start..start + len]);
            }
            None => {
                for p in 0..np {
                    let zero = vec![0.0; pb.primaries_nm.len()];
                    let a = batch.push(s.w, p, false, &zero, None);
                    let b = batch.push(s.w, p, true, &zero, None);
                    pending.push((si, p, a, b));
                }
            }
        }
    }
    batch.run();
    for &(si, p, a, b) in &pending {
        let s = &mut states[si];
        s.pa[p * n..(p + 1) * n].copy_from_slice(batch.percept(a));
        s.pb[p * n..(p + 1) * n].copy_from_slice(batch.percept(b));
    }
    batch.clear();
}

/// Finite-difference Jacobian columns of every active state whose last step was accepted, in
/// one observer call: side B where α_i ≥ 0, side A where α_i ≤ 0.
pub(super) fn jacobian_pass(
    pb: &MatchProblem<'_>,
    settings: &SolverSettings,
    batch: &mut Batch<'_, '_>,
    states: &mut [State],
) {
    let mut fd = Vec::new();
    for (si, s) in states
        .iter()
        .enumerate()
        .filter(|(_, s)| s.active && !s.j_valid)
    {
        for p in 0..pb.pairs[s.w].len() {
            for (i, &ai) in s.alpha.iter().enumerate() {
                if ai >= 0.0 {
                    fd.push((si, p, i, true, batch.push(s.w, p, true, &s.alpha, Some(i))));
                }
                if ai <= 0.0 {
                    fd.push((
                        si,
                        p,
                        i,
                        false,
                        batch.push(s.w, p, false, &s.alpha, Some(i)),
                    ));
                }
            }
        }
    }
    batch.run();
    for &(si, p, i, on_b, show) in &fd {
        states[si].set_column(p, i, on_b, batch.percept(show), settings.fd_step);
    }
    for &(si, ..) in &fd {
        states[si].mark_measured();
    }
    batch.clear();
}

/// One trial step of every active state, shown in one observer call, then accepted or
/// rejected.
pub(super) fn trial_pass(
    pb: &MatchProblem<'_>,
    settings: &SolverSettings,
    options: &MatchOptions<'_>,
    batch: &mut Batch<'_, '_>,
    states: &mut [State],
) {
    let mut trial_shows = Vec::new();
    for (si, s) in states.iter_mut().enumerate().filter(|(_, s)| s.active) {
        let (change_a, change_b) = s.propose();
        for p in 0..pb.pairs[s.w].len() {
            let a = change_a.then(|| batch.push(s.w, p, false, &s.trial, None));
            let b = change_b.then(|| batch.push(s.w, p, true, &s.trial, None));
            trial_shows.push((si, p, a, b));
        }
    }
    batch.run();
    for &(si, p, a, b) in &trial_shows {
        states[si].take_trial(p, a.map(|s| batch.percept(s)), b.map(|s| batch.percept(s)));
    }
    batch.clear();
    for s in states.iter_mut().filter(|s| s.active) {
        s.judge(settings, options.stop_below.map(|t| t[s.w]));
    }
}

/// Offset (in shows) of wavelength `w`'s first pair in a `(wavelengths × pairs)` layout.
fn known_offset(pb: &MatchProblem<'_>, w: usize) -> usize {
    pb.pairs[..w].iter().map(Vec::len).sum()
}
