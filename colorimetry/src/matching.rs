//! The colour-matching solver of CMF-SIM (paper S-04; official §4.1–4.2).
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
//! α is found by Levenberg–Marquardt from α = 0 (official §4.2's "cheaper alternative"): a
//! finite-difference Jacobian (one extra show per primary and pair, on the side the primary is
//! on; both sides, averaged, while α_i = 0), a pure Gauss–Newton step first (μ = 0, exact in one
//! step for a linear, location-independent observer), and on a failed step a damped step
//! `(JᵀJ + μ·diag JᵀJ) δ = −Jᵀr` with μ growing tenfold, which moves towards gradient descent —
//! the fallback for nonlinear observers. All test wavelengths advance in lockstep so that each
//! iteration is one batched [`Observer::percepts`] call.

use crate::linalg::{lstsq, DEFAULT_RCOND};
use crate::observer::{Observer, Show, Stimulus};

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolverSettings {
    /// Maximum LM iterations per wavelength (each one batched observer call).
    pub max_iterations: usize,
    /// Finite-difference step, in units of the test intensity.
    pub fd_step: f64,
    /// Stop when an accepted step improves E by less than this fraction.
    pub rel_tolerance: f64,
    /// Stop when E falls below this fraction of E(0) (an exact match).
    pub exact_match_rel: f64,
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            max_iterations: 12,
            fd_step: 1e-3,
            rel_tolerance: 1e-6,
            exact_match_rel: 1e-14,
        }
    }
}

/// One matching problem: all test wavelengths against one primary set.
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
    /// Base of the per-show noise seeds.
    pub seed: u64,
}

/// The solution for every test wavelength.
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

fn side_a(
    test_nm: f64,
    prim: &[f64],
    alpha: &[f64],
    intensity: f64,
    extra: Option<usize>,
    h: f64,
) -> Stimulus {
    let mut lines = vec![(test_nm, intensity)];
    for (i, (&p, &a)) in prim.iter().zip(alpha).enumerate() {
        let amount = (-a).max(0.0) + if extra == Some(i) { h } else { 0.0 };
        if amount > 0.0 {
            lines.push((p, amount * intensity));
        }
    }
    Stimulus::Lines(lines)
}

fn side_b(prim: &[f64], alpha: &[f64], intensity: f64, extra: Option<usize>, h: f64) -> Stimulus {
    let mut lines = Vec::with_capacity(prim.len());
    for (i, (&p, &a)) in prim.iter().zip(alpha).enumerate() {
        let amount = a.max(0.0) + if extra == Some(i) { h } else { 0.0 };
        if amount > 0.0 {
            lines.push((p, amount * intensity));
        }
    }
    Stimulus::Lines(lines)
}

/// Residuals (pairs × N), Jacobian (pairs × N × K, row-major) and E at one α.
struct Linearisation {
    err: f64,
    r: Vec<f64>,
    j: Vec<f64>,
}

/// Where the shows of one (wavelength, pair) sit in the batch.
struct PairLayout {
    a: usize,
    b: usize,
    /// (primary, show index, show is side B)
    fd: Vec<(usize, usize, bool)>,
}

/// Evaluate E, r and J at `alphas[w]` for every wavelength in `active` with one observer call.
fn linearise(
    pb: &MatchProblem<'_>,
    active: &[usize],
    alphas: &[Vec<f64>],
    h: f64,
    shows: &mut Vec<Show>,
    out: &mut Vec<f64>,
) -> Vec<Linearisation> {
    let n = pb.observer.percept_dim();
    let k = pb.primaries_nm.len();
    let (prim, intensity) = (pb.primaries_nm, pb.intensity);
    shows.clear();
    let mut layout: Vec<Vec<PairLayout>> = Vec::with_capacity(active.len());
    for &w in active {
        let alpha = &alphas[w];
        let test = pb.test_wavelengths_nm[w];
        let mut per_pair = Vec::with_capacity(pb.pairs[w].len());
        for (p, &[loc_a, loc_b]) in pb.pairs[w].iter().enumerate() {
            let (seed_a, seed_b) = (show_seed(pb.seed, w, p, 1), show_seed(pb.seed, w, p, 2));
            let show_a = |extra| Show {
                stimulus: side_a(test, prim, alpha, intensity, extra, h),
                location: loc_a,
                noise_seed: seed_a,
            };
            let show_b = |extra| Show {
                stimulus: side_b(prim, alpha, intensity, extra, h),
                location: loc_b,
                noise_seed: seed_b,
            };
            let a = shows.len();
            shows.push(show_a(None));
            shows.push(show_b(None));
            let mut fd = Vec::with_capacity(2 * k);
            for (i, &ai) in alpha.iter().enumerate() {
                if ai >= 0.0 {
                    fd.push((i, shows.len(), true));
                    shows.push(show_b(Some(i)));
                }
                if ai <= 0.0 {
                    fd.push((i, shows.len(), false));
                    shows.push(show_a(Some(i)));
                }
            }
            per_pair.push(PairLayout { a, b: a + 1, fd });
        }
        layout.push(per_pair);
    }
    out.clear();
    out.resize(shows.len() * n, 0.0);
    pb.observer.percepts(shows, out);
    let pct = |s: usize| &out[s * n..(s + 1) * n];
    layout
        .iter()
        .map(|per_pair| {
            let np = per_pair.len();
            let mut r = vec![0.0; np * n];
            let mut j = vec![0.0; np * n * k];
            let mut count = vec![0.0f64; k];
            let mut err = 0.0;
            for (p, pl) in per_pair.iter().enumerate() {
                let (pa, pbv) = (pct(pl.a), pct(pl.b));
                for d in 0..n {
                    r[p * n + d] = pbv[d] - pa[d];
                    err += r[p * n + d].powi(2);
                }
                count.fill(0.0);
                for &(i, s, on_b) in &pl.fd {
                    // dr/dα_i: on B, more of p_i raises Φ(B); on A, more of p_i means lower α_i,
                    // so (Φ(A') − Φ(A))/h is again dr/dα_i.
                    let base = if on_b { pbv } else { pa };
                    let pert = pct(s);
                    for d in 0..n {
                        j[(p * n + d) * k + i] += (pert[d] - base[d]) / h;
                    }
                    count[i] += 1.0;
                }
                for d in 0..n {
                    for i in 0..k {
                        j[(p * n + d) * k + i] /= count[i].max(1.0);
                    }
                }
            }
            Linearisation {
                err: err / np as f64,
                r,
                j,
            }
        })
        .collect()
}

/// The damped Gauss–Newton step for one wavelength.
fn lm_step(lin: &Linearisation, k: usize, mu: f64) -> Vec<f64> {
    let rows = lin.r.len();
    let mut diag = vec![0.0; k];
    for row in 0..rows {
        for i in 0..k {
            diag[i] += lin.j[row * k + i].powi(2);
        }
    }
    let extra = if mu > 0.0 { k } else { 0 };
    let mut a = Vec::with_capacity((rows + extra) * k);
    a.extend_from_slice(&lin.j);
    let mut b: Vec<f64> = lin.r.iter().map(|v| -v).collect();
    if mu > 0.0 {
        for i in 0..k {
            for c in 0..k {
                a.push(if c == i {
                    (mu * diag[i].max(1e-300)).sqrt()
                } else {
                    0.0
                });
            }
            b.push(0.0);
        }
    }
    lstsq(&a, rows + extra, k, &b, 1, DEFAULT_RCOND).x
}

/// Solve every test wavelength of `pb`.
pub fn solve_matches(pb: &MatchProblem<'_>, settings: &SolverSettings) -> MatchSolution {
    let nw = pb.test_wavelengths_nm.len();
    let k = pb.primaries_nm.len();
    assert_eq!(
        pb.pairs.len(),
        nw,
        "solve_matches: {} pair lists for {nw} wavelengths",
        pb.pairs.len()
    );
    let h = settings.fd_step;
    let mut shows = Vec::new();
    let mut out = Vec::new();
    let mut alphas = vec![vec![0.0; k]; nw];
    let all: Vec<usize> = (0..nw).collect();
    let mut cur = linearise(pb, &all, &alphas, h, &mut shows, &mut out);
    let mut calls = 1;
    let mut n_shows = shows.len();
    let errors_at_zero: Vec<f64> = cur.iter().map(|l| l.err).collect();
    let mut mu = vec![0.0f64; nw];
    let mut active: Vec<usize> = (0..nw)
        .filter(|&w| k > 0 && errors_at_zero[w] > 0.0)
        .collect();
    let mut trial = alphas.clone();
    for _ in 0..settings.max_iterations {
        if active.is_empty() {
            break;
        }
        for &w in &active {
            let step = lm_step(&cur[w], k, mu[w]);
            for i in 0..k {
                trial[w][i] = alphas[w][i] + step[i];
            }
        }
        let lins = linearise(pb, &active, &trial, h, &mut shows, &mut out);
        calls += 1;
        n_shows += shows.len();
        let mut still = Vec::with_capacity(active.len());
        for (lin, &w) in lins.into_iter().zip(&active) {
            let old = cur[w].err;
            if lin.err < old {
                alphas[w].clone_from(&trial[w]);
                let done = old - lin.err <= settings.rel_tolerance * old
                    || lin.err <= settings.exact_match_rel * errors_at_zero[w];
                cur[w] = lin;
                mu[w] = if mu[w] < 1e-9 { 0.0 } else { mu[w] / 10.0 };
                if !done {
                    still.push(w);
                }
            } else if lin.err <= old * (1.0 + settings.rel_tolerance) {
                // No meaningful change either way: α is at the (local) optimum.
            } else {
                mu[w] = if mu[w] == 0.0 { 1e-3 } else { mu[w] * 10.0 };
                if mu[w] < 1e8 {
                    still.push(w);
                }
            }
        }
        active = still;
    }
    MatchSolution {
        errors: cur.iter().map(|l| l.err).collect(),
        alphas,
        errors_at_zero,
        observer_calls: calls,
        shows: n_shows,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::ConeObserver;
    use crate::cones::{ConeClass, ConeTemplate};
    use crate::grid::WavelengthGrid;

    fn lms() -> ConeObserver {
        ConeObserver::new(
            &ConeClass::lms(),
            &ConeTemplate::default(),
            &WavelengthGrid::default(),
        )
        .unwrap()
    }

    #[test]
    fn primary_matches_itself_with_alpha_one() {
        let o = lms();
        let prim = [450.0, 540.0, 610.0];
        let tests = [450.0, 540.0, 610.0, 500.0];
        let pairs = vec![vec![[[-0.5, 0.0], [0.5, 0.0]]]; 4];
        let pb = MatchProblem {
            observer: &o,
            test_wavelengths_nm: &tests,
            primaries_nm: &prim,
            intensity: 1.0,
            pairs: &pairs,
            seed: 1,
        };
        let s = solve_matches(&pb, &SolverSettings::default());
        for (w, a) in s.alphas.iter().take(3).enumerate() {
            for (i, &v) in a.iter().enumerate() {
                let want = if i == w { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-9, "test {w}: α {a:?}");
            }
        }
        // 500 nm needs a negative red (r̄ < 0 between the blue and green primaries)
        assert!(s.alphas[3][2] < 0.0, "{:?}", s.alphas[3]);
        for (e, e0) in s.errors.iter().zip(&s.errors_at_zero) {
            assert!(*e <= 1e-14 * e0, "{e} vs {e0}");
        }
    }

    #[test]
    fn too_few_primaries_leave_a_residual_and_match_least_squares() {
        let o = lms();
        let prim = [450.0, 600.0];
        let tests = [520.0];
        let pairs = vec![vec![[[-0.5, 0.0], [0.5, 0.0]]]];
        let pb = MatchProblem {
            observer: &o,
            test_wavelengths_nm: &tests,
            primaries_nm: &prim,
            intensity: 1.0,
            pairs: &pairs,
            seed: 1,
        };
        let s = solve_matches(&pb, &SolverSettings::default());
        assert!(s.errors[0] > 1e-6 * s.errors_at_zero[0]);
        // compare with the unconstrained linear least-squares optimum
        let col = |w: f64| {
            let mut e = vec![0.0; 3];
            o.excitations_into(&Stimulus::monochromatic(w, 1.0), &mut e);
            e
        };
        let (p0, p1, t) = (col(450.0), col(600.0), col(520.0));
        let a: Vec<f64> = (0..3).flat_map(|d| [p0[d], p1[d]]).collect();
        let best = lstsq(&a, 3, 2, &t, 1, DEFAULT_RCOND).x;
        let res: f64 = (0..3)
            .map(|d| (p0[d] * best[0] + p1[d] * best[1] - t[d]).powi(2))
            .sum();
        assert!(
            (s.errors[0] - res).abs() <= 1e-9 * res,
            "{} vs {res}",
            s.errors[0]
        );
    }
}
