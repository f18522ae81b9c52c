//! CMF-SIM speed on analytic observers (criterion; `cargo bench --bench cmf_sim`).
//!
//! - `cmf_sim/lms_default_grid_500_sets`: the full search with the paper's budget of 500 primary
//!   sets per K and the default 8 location pairs, on the analytic Carroll/Neitz LMS observer
//!   (400–700 nm every 10 nm): K = 1 and K = 2 try all 500 sets and fail, K = 3 passes with its
//!   first set, so this is 1001 primary sets × 100 test wavelengths.
//! - `cmf_sim/lms_1nm_grid_20_sets`: the test setting (20 sets per K, 1 location pair) on the
//!   official 1 nm grid.
//!
//! Each run prints the observer calls and shows evaluated once, so the cost of a trained
//! observer can be estimated as shows × (time per show of the retina + cortex).
//! - `cmf_sim/paper_eye_16_shows_window` and `…_whole_field`: one batch of 16 shows (8 at each
//!   of two patch locations, the cached noise-free path CMF-SIM takes) through the `paper`
//!   preset's eye (256 × 256 cones) and its cortex (8 → 16/32/64/128 → 8 U-Net), decoder D on
//!   the window each patch needs or on the whole field; their ratio is the saving per show.

use colorimetry::analytic::ConeObserver;
use colorimetry::observer::{Observer, Show, Stimulus};
use colorimetry::{run_cmf_sim, CmfSimSettings, ConeClass, ConeTemplate, WavelengthGrid};
use cortex::Cortex;
use criterion::{criterion_group, criterion_main, Criterion};
use retina::Retina;
use science::config::RunConfig;
use science::observer::{EyeObserver, ObserverSettings};
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("cmf_sim");
    g.sample_size(10).measurement_time(Duration::from_secs(20));

    let lms = ConeObserver::new(
        &ConeClass::lms(),
        &ConeTemplate::default(),
        &WavelengthGrid::default(),
    )
    .expect("valid observer");
    let paper = CmfSimSettings::default();
    let r = run_cmf_sim(&lms, &paper).expect("runs");
    println!(
        "paper budget: dimension {}, sets per K {:?}, {} observer calls, {} shows, {:.2} s",
        r.dimension,
        r.per_k.iter().map(|k| k.sets_tried).collect::<Vec<_>>(),
        r.observer_calls,
        r.shows,
        r.seconds
    );
    g.bench_function("lms_default_grid_500_sets", |b| {
        b.iter(|| black_box(run_cmf_sim(&lms, &paper).unwrap().dimension))
    });

    let lms_1nm = ConeObserver::new(
        &ConeClass::lms(),
        &ConeTemplate::default(),
        &WavelengthGrid::official_1nm(),
    )
    .expect("valid observer");
    let fast = CmfSimSettings {
        sets_per_k: 20,
        location_pairs: 1,
        ..CmfSimSettings::default()
    };
    g.bench_function("lms_1nm_grid_20_sets", |b| {
        b.iter(|| black_box(run_cmf_sim(&lms_1nm, &fast).unwrap().dimension))
    });
    g.finish();
}

/// 16 shows of monochromatic lights, 8 at each of two locations.
fn paper_shows() -> Vec<Show> {
    (0..16)
        .map(|i| Show {
            stimulus: Stimulus::monochromatic(420.0 + 17.0 * i as f64, 0.5),
            location: if i % 2 == 0 { [0.3, -0.4] } else { [-0.5, 0.2] },
            noise_seed: 0,
        })
        .collect()
}

fn paper_eye(c: &mut Criterion) {
    let mut g = c.benchmark_group("cmf_sim");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    let config = RunConfig::preset("paper", "LMS").expect("paper preset");
    let retina = Retina::new(config.retina.clone()).expect("paper eye");
    let cortex = Cortex::new(config.cortex.clone()).expect("paper cortex");
    let shows = paper_shows();
    for (name, whole) in [("window", false), ("whole_field", true)] {
        let mut o = EyeObserver::cortex(&retina, &cortex, ObserverSettings::default());
        if whole {
            o = o.decoding_whole_field();
        }
        let mut out = vec![0.0; shows.len() * o.percept_dim()];
        o.percepts(&shows, &mut out); // fills the per-location cache
        g.bench_function(format!("paper_eye_16_shows_{name}"), |b| {
            b.iter(|| {
                o.percepts(&shows, &mut out);
                black_box(out[0])
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench, paper_eye);
criterion_main!(benches);
