//! The hidden-signal figures are converged at their default count. A kept cortex (the human-Q
//! protocol's control on its screen seed, `results/humanq-H0-seed51`: a quick LMSQ eye trained
//! 24 000 steps with one scene tile in ten idealised, the environment whose rare tiles make
//! the figures hardest to pin down) is measured on two independent held-out streams (other run
//! and scene seeds: other tiles, crops and noise), each a fresh tile every batch
//! (`science::heldout::hidden_source`). At [`HELD_OUT_SCENES`] every class's unique R² agrees
//! between the two within 0.05; at 32 scenes, the count a run's summary once used, they do not
//! (the check the test can fail). `cargo test --release --test hidden_convergence -- --nocapture`
//! prints the figures.

use colorvision::run::folder::load_run_at;
use science::config::RunConfig;
use science::invariants::{measure_held_out, HELD_OUT_SCENES};
use std::path::Path;

/// Every class's unique R² of the kept cortex on `scenes` scenes of the held-out stream of
/// `config` with its run and scene seeds moved by `shift`.
fn figures(config: &RunConfig, cortex: &cortex::Cortex, shift: u64, scenes: usize) -> Vec<f64> {
    let mut moved = config.clone();
    moved.seed = moved.seed.wrapping_add(shift);
    moved.retina.scene_seed = moved.retina.scene_seed.wrapping_add(shift);
    let mut source = science::heldout::hidden_source(&moved).unwrap();
    measure_held_out(cortex, &mut source, scenes).0.unique_r2
}

fn widest_gap(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn hidden_figures_agree_across_independent_streams_at_the_default_count() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (config, trainer, _) = load_run_at(&root.join("results/humanq-H0-seed51"), 24_000).unwrap();
    let cortex = &trainer.cortex;
    let (a, b) = (
        figures(&config, cortex, 1, HELD_OUT_SCENES),
        figures(&config, cortex, 2, HELD_OUT_SCENES),
    );
    println!("{HELD_OUT_SCENES} scenes: {a:.3?} / {b:.3?}");
    assert!(
        widest_gap(&a, &b) <= 0.05,
        "{HELD_OUT_SCENES} scenes: {a:.3?} against {b:.3?}"
    );
    assert!(
        a.iter().all(|r| *r > 0.3),
        "the kept cortex carries every class's own signal: {a:.3?}"
    );
    let (few_a, few_b) = (
        figures(&config, cortex, 1, 32),
        figures(&config, cortex, 2, 32),
    );
    println!("32 scenes: {few_a:.3?} / {few_b:.3?}");
    assert!(
        widest_gap(&few_a, &few_b) > 0.05,
        "32 scenes should not be enough: {few_a:.3?} against {few_b:.3?}"
    );
}
