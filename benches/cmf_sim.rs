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

use colorimetry::analytic::ConeObserver;
use colorimetry::{run_cmf_sim, CmfSimSettings, ConeClass, ConeTemplate, WavelengthGrid};
use criterion::{criterion_group, criterion_main, Criterion};
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

criterion_group!(benches, bench);
criterion_main!(benches);
