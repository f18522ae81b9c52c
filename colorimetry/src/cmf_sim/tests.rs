//! CMF-SIM on analytic observers whose dimension is known.
//!
//! Fast settings: 20 primary sets per K (the paper uses 500), one location pair per evaluation
//! for the location-independent observers, the default 400–700 nm / 10 nm grid.

use super::*;
use crate::analytic::{ConeObserver, LocationDependentObserver, NakaRushtonObserver};
use crate::cones::{ConeClass, ConeTemplate};
use crate::matching::tests::WithFrontEnd;
use crate::observer::{percept_of, Show, Stimulus};

fn fast(seed: u64) -> CmfSimSettings {
    CmfSimSettings {
        sets_per_k: 20,
        location_pairs: 1,
        seed,
        ..CmfSimSettings::default()
    }
}

fn cones(classes: &[ConeClass]) -> ConeObserver {
    ConeObserver::new(
        classes,
        &ConeTemplate::default(),
        &WavelengthGrid::default(),
    )
    .unwrap()
}

fn dimension_of(o: &dyn Observer, seed: u64) -> CmfSimResult {
    let r = run_cmf_sim(o, &fast(seed)).unwrap();
    assert!(!r.no_colour_constancy, "{}: {}", r.observer, r.verdict);
    r
}

#[test]
fn cone_observers_have_dimension_k() {
    let (l, m, s) = (ConeClass::l(), ConeClass::m(), ConeClass::s());
    let cases: Vec<(Vec<ConeClass>, usize)> = vec![
        (vec![l.clone()], 1),
        (vec![m.clone()], 1),
        (vec![l.clone(), m.clone()], 2),
        (vec![l.clone(), s.clone()], 2),
        (vec![m.clone(), s.clone()], 2),
        (ConeClass::lms(), 3),
        (
            vec![l.clone(), m.clone(), s.clone(), ConeClass::pigeon_q()],
            4,
        ),
        (vec![l, m, s, ConeClass::human_q()], 4),
    ];
    for (i, (classes, k)) in cases.iter().enumerate() {
        let k = *k;
        let o = cones(classes);
        let r = dimension_of(&o, 11 + i as u64);
        assert_eq!(
            r.dimension, k,
            "{}: {} (per K {:?})",
            r.observer, r.verdict, r.per_k
        );
        let ratios: Vec<String> = r.curves[1..]
            .iter()
            .map(|c| format!("K={} worst {:.2e}", c.n_primaries, c.worst_ratio))
            .collect();
        eprintln!(
            "{}: dimension {} [{}]",
            r.observer,
            r.dimension,
            ratios.join(", ")
        );
        // every smaller K tried its full budget and failed; K itself passed
        for ks in &r.per_k[..k - 1] {
            assert!(!ks.passed && ks.sets_tried == 20, "{}: {ks:?}", r.observer);
        }
        assert!(r.per_k[k - 1].passed);
        // the margins agree with the verdicts: ≥ 1 for every failed K, < 1 for K; a converged
        // margin is never below the lower bound early rejection saw
        for ks in &r.per_k {
            let bound = ks.lower_bound_ratio().expect("sets were tried");
            let margin = ks.converged_worst_ratio;
            assert_eq!(
                margin < 1.0,
                ks.passed,
                "{}: K={} {margin}",
                r.observer,
                ks.n_primaries
            );
            assert_eq!(ks.failing_wavelengths == 0, ks.passed, "{ks:?}");
            if !ks.passed {
                assert!(
                    margin >= bound,
                    "K={}: {margin} < bound {bound}",
                    ks.n_primaries
                );
                assert!(ks.sets_fully_evaluated >= 1);
            }
        }
        assert_eq!(r.curves.len(), k + 1);
        // areas shrink from the energy curve down to the passing set
        assert!(r.curves[k].area < 1e-6 * r.curves[0].area);
    }
}

#[test]
fn rank_deficient_observer_has_dimension_3() {
    let o = ConeObserver::rank_deficient_lms(&ConeTemplate::default(), &WavelengthGrid::default())
        .unwrap();
    assert_eq!(o.percept_dim(), 4);
    let r = dimension_of(&o, 5);
    assert_eq!(r.dimension, 3, "{}", r.verdict);
}

#[test]
fn nonlinear_observer_is_solved_iteratively() {
    // The L excitation of a unit monochromatic light at its peak is ≈ 1 on the 10 nm grid, so
    // σ = 0.5 compresses strongly; the match is still exact in cone space.
    let o = NakaRushtonObserver::new(cones(&ConeClass::lms()), 0.5);
    let r = dimension_of(&o, 21);
    assert_eq!(r.dimension, 3, "{} {:?}", r.verdict, r.per_k);
    let worst: Vec<String> = r
        .curves
        .iter()
        .map(|c| format!("{:.2e}", c.worst_ratio))
        .collect();
    eprintln!(
        "Naka–Rushton: worst ratios per K {worst:?}, {} observer calls",
        r.observer_calls
    );
}

#[test]
fn location_dependent_observer_fails_the_base_error_test() {
    let o = LocationDependentObserver::new(cones(&ConeClass::lms()), 4, 3);
    let settings = CmfSimSettings {
        location_pairs: 4,
        ..fast(9)
    };
    let r = run_cmf_sim(&o, &settings).unwrap();
    assert!(r.no_colour_constancy, "{}", r.verdict);
    assert_eq!(r.dimension, 0);
    assert!(r.per_k.is_empty());
    let (b, e): (f64, f64) = (r.base_error.iter().sum(), r.energy.iter().sum());
    assert!(b > e, "base {b} energy {e}");
}

#[test]
fn too_small_a_budget_is_reported_not_guessed() {
    let o = cones(&ConeClass::lms());
    let settings = CmfSimSettings {
        max_primaries: 2,
        ..fast(1)
    };
    let r = run_cmf_sim(&o, &settings).unwrap();
    assert_eq!(r.dimension, 0);
    assert!(r.verdict.contains("K ≤ 2"), "{}", r.verdict);
}

#[test]
fn a_stop_request_ends_the_search_and_a_progress_callback_can_request_it() {
    let o = cones(&ConeClass::lms());
    let stop = std::sync::atomic::AtomicBool::new(false);
    let mut sets = 0;
    let r = run_cmf_sim_until(
        &o,
        &fast(1),
        &mut |_| {
            sets += 1;
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
        },
        &stop,
    );
    assert!(matches!(r, Err(ColorimetryError::Stopped)), "{r:?}");
    assert_eq!(sets, 1, "the search stops before the next set");
}

#[test]
fn a_separation_wider_than_a_band_is_refused_before_any_show() {
    let o = cones(&ConeClass::lms());
    let bad = CmfSimSettings {
        min_primary_separation_nm: 1000.0,
        ..fast(1)
    };
    let e = run_cmf_sim(&o, &bad).unwrap_err().to_string();
    assert!(
        e.contains("min_primary_separation_nm") && e.contains("bands"),
        "{e}"
    );
}

/// Margins past the first pass: an L, M observer (2-D) measured through K = 4 still reads 2,
/// its K = 1 and 2 exactly as the stopping search reads them, and K = 3 and 4 pass with margins
/// below 1; through a K above `max_primaries` is refused, naming the setting.
#[test]
fn margins_through_k_go_past_the_pass_and_keep_the_dimension() {
    let o = cones(&[ConeClass::l(), ConeClass::m()]);
    let stopping = run_cmf_sim(&o, &fast(5)).unwrap();
    let through = CmfSimSettings {
        margins_through_k: 4,
        ..fast(5)
    };
    let r = run_cmf_sim(&o, &through).unwrap();
    assert_eq!((stopping.dimension, r.dimension), (2, 2), "{}", r.verdict);
    assert_eq!(r.verdict, stopping.verdict);
    let ks: Vec<usize> = r.per_k.iter().map(|k| k.n_primaries).collect();
    assert_eq!(ks, [1, 2, 3, 4]);
    let untimed = |ks: &[KSummary]| {
        let mut ks = ks.to_vec();
        ks.iter_mut().for_each(|k| k.seconds = 0.0);
        ks
    };
    assert_eq!(untimed(&r.per_k[..2]), untimed(&stopping.per_k));
    assert_eq!(r.curves[..3], stopping.curves[..]);
    for k in &r.per_k[2..] {
        assert!(
            k.passed && k.converged_worst_ratio < 1.0,
            "K = {}: {k:?}",
            k.n_primaries
        );
    }
    assert_eq!(r.curves.len(), 5);
    let refused = CmfSimSettings {
        margins_through_k: 7,
        ..fast(5)
    };
    let e = run_cmf_sim(&o, &refused).unwrap_err().to_string();
    assert!(e.contains("margins_through_k"), "{e}");
}

#[test]
fn settings_outside_the_grid_are_errors() {
    let o = cones(&ConeClass::lms());
    let bad = CmfSimSettings {
        test_range_nm: (380.0, 700.0),
        ..fast(1)
    };
    let e = run_cmf_sim(&o, &bad).unwrap_err().to_string();
    assert!(e.contains("test_range_nm"), "{e}");
    let bad = CmfSimSettings {
        sets_per_k: 0,
        ..fast(1)
    };
    assert!(run_cmf_sim(&o, &bad).is_err());
}

#[test]
fn stratified_primaries_respect_bands_and_spacing() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(4);
    for k in 1..=6 {
        for _ in 0..50 {
            let p = stratified_primaries(k, (400.0, 700.0), 5.0, &mut rng).unwrap();
            let w = 300.0 / k as f64;
            for (i, &v) in p.iter().enumerate() {
                assert!(v >= 400.0 + w * i as f64 && v <= 400.0 + w * (i + 1) as f64);
            }
            assert!(p.windows(2).all(|x| x[1] - x[0] >= 5.0));
        }
    }
    assert!(stratified_primaries(100, (400.0, 700.0), 5.0, &mut rng).is_err());
}

/// Observers for the early-rejection and front-end comparisons (two location pairs, so that
/// matches are judged over more than one pair).
fn comparison_observers() -> Vec<(Box<dyn Observer>, usize)> {
    let (l, m, s) = (ConeClass::l(), ConeClass::m(), ConeClass::s());
    let tetra = vec![l.clone(), m.clone(), s.clone(), ConeClass::pigeon_q()];
    let rank_deficient =
        ConeObserver::rank_deficient_lms(&ConeTemplate::default(), &WavelengthGrid::default())
            .unwrap();
    vec![
        (Box::new(cones(&[l.clone(), s])), 2),
        (Box::new(cones(&ConeClass::lms())), 3),
        (Box::new(cones(&tetra)), 4),
        (Box::new(rank_deficient), 3),
        (
            Box::new(NakaRushtonObserver::new(cones(&ConeClass::lms()), 0.5)),
            3,
        ),
        (Box::new(cones(&[m])), 1),
    ]
}

#[test]
fn early_rejection_gives_the_verdicts_of_full_evaluation() {
    for (i, (o, k)) in comparison_observers().iter().enumerate() {
        let settings = CmfSimSettings {
            location_pairs: 2,
            front_end_jacobians: false,
            ..fast(31 + i as u64)
        };
        let early = run_cmf_sim(o.as_ref(), &settings).unwrap();
        let full = run_cmf_sim(
            o.as_ref(),
            &CmfSimSettings {
                early_rejection: false,
                ..settings.clone()
            },
        )
        .unwrap();
        assert_eq!((early.dimension, full.dimension), (*k, *k), "{}", o.name());
        assert_eq!(early.per_k.len(), full.per_k.len());
        for (e, f) in early.per_k.iter().zip(&full.per_k) {
            // the same sets, the same verdict for every one of them
            assert_eq!(
                (e.sets_tried, e.passed),
                (f.sets_tried, f.passed),
                "{}",
                o.name()
            );
            for (se, sf) in e.sets.iter().zip(&f.sets) {
                assert_eq!(se.primaries_nm, sf.primaries_nm);
                assert_eq!(se.passed, sf.passed, "{}: {se:?} vs {sf:?}", o.name());
                assert!(se.wavelengths_solved <= sf.wavelengths_solved);
            }
        }
        // the passing set is reported fully evaluated, identical in both modes
        let (ce, cf) = (&early.curves[*k], &full.curves[*k]);
        assert!(ce.fully_evaluated && cf.fully_evaluated && ce.passed);
        assert_eq!(ce.set_index, cf.set_index);
        for (a, b) in ce.errors.iter().zip(&cf.errors) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-300), "{a} vs {b}");
        }
        // every reported curve covers every wavelength
        assert!(early
            .curves
            .iter()
            .all(|c| c.errors.len() == early.test_wavelengths_nm.len()));
        // early rejection solved far fewer wavelengths for the failing K
        let solves = |r: &CmfSimResult| r.per_k.iter().map(|s| s.wavelength_solves).sum::<usize>();
        if *k > 1 {
            assert!(solves(&early) * 2 < solves(&full), "{}", o.name());
            assert!(early.shows < full.shows);
        }
    }
}

#[test]
fn front_end_model_keeps_the_dimension_exact() {
    let lms = cones(&ConeClass::lms());
    let tetra_classes = vec![
        ConeClass::l(),
        ConeClass::m(),
        ConeClass::s(),
        ConeClass::pigeon_q(),
    ];
    let tetra = cones(&tetra_classes);
    let rank_deficient =
        ConeObserver::rank_deficient_lms(&ConeTemplate::default(), &WavelengthGrid::default())
            .unwrap();
    let cases: Vec<(Box<dyn Observer>, usize)> = vec![
        (
            Box::new(WithFrontEnd::new(cones(&ConeClass::lms()), &lms)),
            3,
        ),
        (
            Box::new(WithFrontEnd::new(cones(&tetra_classes), &tetra)),
            4,
        ),
        (
            Box::new(WithFrontEnd::new(rank_deficient.clone(), &rank_deficient)),
            3,
        ),
        (
            Box::new(WithFrontEnd::new(
                NakaRushtonObserver::new(cones(&ConeClass::lms()), 0.5),
                &lms,
            )),
            3,
        ),
    ];
    for (i, (o, k)) in cases.iter().enumerate() {
        let settings = CmfSimSettings {
            location_pairs: 2,
            ..fast(41 + i as u64)
        };
        let with = run_cmf_sim(o.as_ref(), &settings).unwrap();
        assert_eq!(with.dimension, *k, "{}: {}", o.name(), with.verdict);
        let without = run_cmf_sim(
            o.as_ref(),
            &CmfSimSettings {
                front_end_jacobians: false,
                ..settings.clone()
            },
        )
        .unwrap();
        assert_eq!(without.dimension, *k);
        assert!(with.curves[*k].worst_ratio < 1.0);
        eprintln!(
            "{}: {} shows with the front-end model, {} without",
            o.name(),
            with.shows,
            without.shows
        );
    }
}

/// A nonlinear observer whose matches have several minima: each cone excitation `v` is seen as
/// `(v − f)²`, folded at `f` = half the largest excitation a test light gives that class, so
/// two excitations map to every percept value and a solve can end in either.
struct FoldedObserver {
    inner: ConeObserver,
    fold: Vec<f64>,
}

impl FoldedObserver {
    fn new(inner: ConeObserver) -> Self {
        let intensity = inner.stimulus_intensity();
        let mut fold = vec![0.0; inner.percept_dim()];
        for w in (400..=700).step_by(10) {
            let p = percept_of(
                &inner,
                Stimulus::monochromatic(w as f64, intensity),
                [0.0; 2],
            );
            for (f, v) in fold.iter_mut().zip(&p) {
                *f = f64::max(*f, 0.5 * v);
            }
        }
        FoldedObserver { inner, fold }
    }
}

impl Observer for FoldedObserver {
    fn name(&self) -> String {
        format!("folded {}", self.inner.name())
    }
    fn grid(&self) -> &WavelengthGrid {
        self.inner.grid()
    }
    fn percept_dim(&self) -> usize {
        self.inner.percept_dim()
    }
    fn stimulus_intensity(&self) -> f64 {
        self.inner.stimulus_intensity()
    }
    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        self.inner.percepts(shows, out);
        for row in out.chunks_mut(self.fold.len()) {
            for (v, f) in row.iter_mut().zip(&self.fold) {
                *v = (*v - f) * (*v - f);
            }
        }
    }
}

#[test]
fn bounded_candidates_report_what_converging_every_candidate_reports() {
    let stop = AtomicBool::new(false);
    let mut saved = 0;
    let folded: Box<dyn Observer> = Box::new(FoldedObserver::new(cones(&ConeClass::lms())));
    let observers = comparison_observers()
        .into_iter()
        .map(|(o, k)| (o, Some(k)))
        .chain([(folded, None)]);
    for (i, (o, k)) in observers.enumerate() {
        let settings = CmfSimSettings {
            location_pairs: 2,
            converged_sets: 5,
            ..fast(47 + i as u64)
        };
        let bounded = run(o.as_ref(), &settings, &mut |_| {}, &stop, true).unwrap();
        let every = run(o.as_ref(), &settings, &mut |_| {}, &stop, false).unwrap();
        eprintln!(
            "{}: {} shows bounded, {} converging every candidate",
            o.name(),
            bounded.shows,
            every.shows
        );
        let k = k.unwrap_or(every.dimension);
        assert_eq!((bounded.dimension, every.dimension), (k, k), "{}", o.name());
        for (b, e) in bounded.per_k.iter().zip(&every.per_k) {
            assert_eq!(b.sets, e.sets, "{}: the same sets tried", o.name());
            assert_eq!(
                (
                    b.sets_fully_evaluated + b.sets_bounded_out,
                    e.sets_bounded_out
                ),
                (e.sets_fully_evaluated, 0),
                "{}: every candidate either converged or bounded out",
                o.name()
            );
            assert!(
                b.shows <= e.shows,
                "{}: {} > {} shows",
                o.name(),
                b.shows,
                e.shows
            );
            saved += e.shows - b.shows;
        }
        for (cb, ce) in bounded.curves.iter().zip(&every.curves) {
            assert_eq!(
                (cb.set_index, &cb.primaries_nm, cb.passed),
                (ce.set_index, &ce.primaries_nm, ce.passed),
                "{}: K = {}",
                o.name(),
                cb.n_primaries
            );
            for (a, b) in cb.errors.iter().zip(&ce.errors) {
                assert!(
                    (a - b).abs() <= 1e-12 * b.abs().max(1e-300),
                    "{}: K = {}: {a} vs {b}",
                    o.name(),
                    cb.n_primaries
                );
            }
        }
    }
    assert!(saved > 0, "the bound never spared a show");
}
