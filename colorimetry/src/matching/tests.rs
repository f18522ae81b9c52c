//! Tests of the matching solver on analytic observers (exact answers known), and
//! [`WithFrontEnd`], an analytic observer that declares its linear front end.
use super::*;
use crate::analytic::{ConeObserver, NakaRushtonObserver};
use crate::cones::{ConeClass, ConeTemplate};
use crate::grid::WavelengthGrid;

/// `inner`, declaring the cone excitations of `cones` as its linear front end (true for a cone
/// observer and anything that transforms its percept pointwise).
pub(crate) struct WithFrontEnd<O> {
    pub inner: O,
    rows: Vec<Vec<f64>>,
}

impl<O: Observer> WithFrontEnd<O> {
    pub fn new(inner: O, cones: &ConeObserver) -> Self {
        let g = cones.grid().len();
        let k = cones.fundamentals().n_classes();
        let mut rows = vec![vec![0.0; g]; k];
        let mut e = vec![0.0; k];
        for i in 0..g {
            let mut s = vec![0.0; g];
            s[i] = 1.0;
            cones.excitations_into(&Stimulus::Spectrum(s), &mut e);
            for (row, v) in rows.iter_mut().zip(&e) {
                row[i] = *v;
            }
        }
        WithFrontEnd { inner, rows }
    }
}

impl<O: Observer> Observer for WithFrontEnd<O> {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn grid(&self) -> &WavelengthGrid {
        self.inner.grid()
    }
    fn percept_dim(&self) -> usize {
        self.inner.percept_dim()
    }
    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        self.inner.percepts(shows, out)
    }
    fn stimulus_intensity(&self) -> f64 {
        self.inner.stimulus_intensity()
    }
    fn linear_front_end(&self) -> Option<Vec<Vec<f64>>> {
        Some(self.rows.clone())
    }
}

fn lms() -> ConeObserver {
    ConeObserver::new(
        &ConeClass::lms(),
        &ConeTemplate::default(),
        &WavelengthGrid::default(),
    )
    .unwrap()
}

/// A problem at intensity 1 with the given test wavelengths, primaries, pairs and seed.
pub(crate) fn problem<'a>(
    observer: &'a dyn Observer,
    tests: &'a [f64],
    prim: &'a [f64],
    pairs: &'a [Vec<[[f64; 2]; 2]>],
    seed: u64,
) -> MatchProblem<'a> {
    MatchProblem {
        observer,
        test_wavelengths_nm: tests,
        primaries_nm: prim,
        intensity: 1.0,
        pairs,
        seed,
    }
}

#[test]
fn primary_matches_itself_with_alpha_one() {
    let o = lms();
    let prim = [450.0, 540.0, 610.0];
    let tests = [450.0, 540.0, 610.0, 500.0];
    let pairs = vec![vec![[[-0.5, 0.0], [0.5, 0.0]]]; 4];
    let pb = problem(&o, &tests, &prim, &pairs, 1);
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
    let pb = problem(&o, &tests, &prim, &pairs, 1);
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

fn naka_rushton() -> NakaRushtonObserver {
    NakaRushtonObserver::new(lms(), 0.5)
}

/// `pairs` location pairs for each of `n` test wavelengths, all distinct.
pub(crate) fn problem_pairs(n: usize, pairs: usize) -> Vec<Vec<[[f64; 2]; 2]>> {
    (0..n)
        .map(|w| {
            (0..pairs)
                .map(|p| {
                    let x = 0.1 * (w + p) as f64 - 0.5;
                    [[x, -0.3], [-x, 0.4]]
                })
                .collect()
        })
        .collect()
}

#[test]
fn stopping_below_a_threshold_and_resuming_follow_the_uninterrupted_path() {
    let o = naka_rushton();
    let tests = [430.0, 480.0, 520.0, 575.0, 640.0];
    let prim = [455.0, 530.0, 610.0];
    let pairs = problem_pairs(tests.len(), 2);
    let pb = problem(&o, &tests, &prim, &pairs, 3);
    let s = SolverSettings::default();
    let all: Vec<usize> = (0..tests.len()).collect();
    let full = solve_wavelengths(&pb, &s, &all, &MatchOptions::default());
    // a threshold a little below E(0)/100: every wavelength stops early, below it
    let stop: Vec<f64> = full
        .matches
        .iter()
        .map(|m| m.error_at_zero * 1e-2)
        .collect();
    let opts = MatchOptions {
        stop_below: Some(&stop),
        ..MatchOptions::default()
    };
    let early = solve_wavelengths(&pb, &s, &all, &opts);
    for (e, f) in early.matches.iter().zip(&full.matches) {
        assert!(e.stopped_below && e.error < stop[e.wavelength], "{e:?}");
        assert!(
            e.iterations < f.iterations,
            "{} vs {}",
            e.iterations,
            f.iterations
        );
        assert!(e.resume.is_some());
    }
    assert!(early.shows < full.shows);
    // continuing reproduces the uninterrupted solve exactly
    let resumed = solve_wavelengths(
        &pb,
        &s,
        &all,
        &MatchOptions {
            resume: Some(&early.matches),
            ..MatchOptions::default()
        },
    );
    for (r, f) in resumed.matches.iter().zip(&full.matches) {
        assert_eq!(
            (&r.alpha, r.error, r.iterations),
            (&f.alpha, f.error, f.iterations)
        );
    }
    assert_eq!(early.shows + resumed.shows, full.shows);
}

#[test]
fn known_percepts_at_zero_are_not_shown_again() {
    let o = naka_rushton();
    let tests = [450.0, 560.0, 610.0];
    let prim = [470.0, 600.0];
    let pairs = problem_pairs(tests.len(), 3);
    let pb = problem(&o, &tests, &prim, &pairs, 8);
    let (mut side_a, mut side_b) = (Vec::new(), Vec::new());
    for (w, &t) in tests.iter().enumerate() {
        for &[a, b] in &pairs[w] {
            side_a.extend(crate::observer::percept_of(
                &o,
                Stimulus::monochromatic(t, 1.0),
                a,
            ));
            side_b.extend(crate::observer::percept_of(&o, Stimulus::black(), b));
        }
    }
    let s = SolverSettings::default();
    let plain = solve_wavelengths(&pb, &s, &[2, 0], &MatchOptions::default());
    let known = solve_wavelengths(
        &pb,
        &s,
        &[2, 0],
        &MatchOptions {
            known_at_zero: Some(KnownAtZero {
                side_a: &side_a,
                side_b: &side_b,
            }),
            ..MatchOptions::default()
        },
    );
    assert_eq!(plain.matches, known.matches);
    assert_eq!(plain.matches[0].wavelength, 2);
    assert_eq!(known.shows + 2 * 2 * 3, plain.shows);
}

#[test]
fn front_end_model_gives_the_exact_first_step_on_a_linear_observer() {
    let cones = lms();
    let o = WithFrontEnd::new(lms(), &cones);
    let tests = [430.0, 500.0, 585.0, 650.0];
    let prim = [445.0, 525.0, 640.0];
    let pairs = problem_pairs(tests.len(), 2);
    let pb = problem(&o, &tests, &prim, &pairs, 5);
    let mut f = FrontEndJacobians::new(&o, tests.len(), 1.0, 1e-3).unwrap();
    let (mut at_a, mut at_b) = (Vec::new(), Vec::new());
    for (w, &t) in tests.iter().enumerate() {
        for &[a, b] in &pairs[w] {
            at_a.extend(crate::observer::percept_of(
                &o,
                Stimulus::monochromatic(t, 1.0),
                a,
            ));
            at_b.extend(crate::observer::percept_of(
                &o,
                Stimulus::monochromatic(t, 1.0),
                b,
            ));
        }
    }
    let shown = f.measure(
        &pb,
        &[0, 1, 2, 3],
        TestPercepts {
            at_a: &at_a,
            at_b: &at_b,
        },
    );
    assert_eq!(shown, tests.len() * 2 * 2 * 3);
    assert!(f.has(3) && !f.has(4));
    let all: Vec<usize> = (0..tests.len()).collect();
    let s = SolverSettings::default();
    let with = solve_wavelengths(
        &pb,
        &s,
        &all,
        &MatchOptions {
            front_end: Some(&f),
            ..MatchOptions::default()
        },
    );
    let without = solve_wavelengths(&pb, &s, &all, &MatchOptions::default());
    for (a, b) in with.matches.iter().zip(&without.matches) {
        // an exact match after one trial, without differences in α
        assert_eq!(a.iterations, 1, "{a:?}");
        assert!(a.error <= 1e-20 * a.error_at_zero, "{a:?}");
        for (x, y) in a.alpha.iter().zip(&b.alpha) {
            assert!(
                (x - y).abs() <= 1e-6 * (1.0 + y.abs()),
                "{:?} vs {:?}",
                a.alpha,
                b.alpha
            );
        }
    }
    assert!(
        with.shows < without.shows / 2,
        "{} vs {}",
        with.shows,
        without.shows
    );
}

#[test]
fn kink_step_takes_each_primary_to_its_better_side_and_stops_at_kinks() {
    // columns (row-major 3 × 2): J⁺_0 = (1, 0, 0), J⁺_1 = (0, 0, 1); J⁻_0 = (1, 1, 0),
    // J⁻_1 = (0, 0, −1)
    let jb = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
    let ja = [1.0, 0.0, 1.0, 0.0, 0.0, -1.0];
    // r = (1, 1, 0): on side B primary 0 would need δ0 = −1 (wrong sign); on side A δ0 = −1
    // matches exactly; primary 1 cannot help and stays at 0
    let s = kink_step(&[1.0, 1.0, 0.0], &ja, &jb, &[0.0, 0.0], 0.0);
    assert!((s.delta[0] + 1.0).abs() < 1e-12, "{s:?}");
    assert_eq!(s.delta[1], 0.0);
    assert!(s.model_residual < 1e-20, "{s:?}");
    // from α_0 = 0.5 (side B) the model's optimum α_0 = −1 lies across the kink: stop at 0
    let s = kink_step(&[1.5, 0.0, 0.0], &ja, &jb, &[0.5, 0.0], 0.0);
    assert_eq!(s.delta, vec![-0.5, 0.0], "{s:?}");
    assert!((s.model_residual - 1.0).abs() < 1e-12);
}
