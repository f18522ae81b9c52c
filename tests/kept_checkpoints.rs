//! Kept checkpoints read again. The records keep trained cortices with their parameters only
//! (`scripts/record-run.sh`): the paper anchor's 256 × 256 eye at 1 000 steps
//! (`results/slow-colour-anchor-paper-seed0-10k`) and a quick tetrachromat that reads 4-D at
//! 96 000 steps (`results/fourth-A2b-seed23`). On each, CMF-SIM's windowed decoding (D's encoder
//! on the window a show reaches, its decoder on the box of cells read) gives the percepts the
//! whole field's decoding gives, within 1e-5 of the largest value, at the centre, near each
//! border and in the corners, for lines, a black patch and a broad light.

use colorimetry::observer::{Observer, Show, Stimulus};
use colorvision::run::folder::load_run_at;
use retina::Retina;
use science::observer::EyeObserver;
use std::path::Path;

/// Shows over the field: every location the default border margin allows a patch centre,
/// from the centre to the corners, with three kinds of light.
fn shows() -> Vec<Show> {
    let edge = 1.0 - colorimetry::observer::DEFAULT_BORDER_MARGIN;
    let locations = [
        [0.0, 0.0],
        [edge, 0.0],
        [-edge, 0.0],
        [0.0, edge],
        [0.0, -edge],
        [edge, edge],
        [-edge, -edge],
        [0.37, -0.61],
    ];
    let lights = [
        Stimulus::monochromatic(455.5, 0.8),
        Stimulus::Lines(vec![(530.0, 0.3), (612.7, 1.1)]),
        Stimulus::black(),
        Stimulus::Lines(vec![(401.0, 2.0), (560.0, 0.05), (699.0, 0.7)]),
    ];
    locations
        .iter()
        .enumerate()
        .map(|(i, &location)| Show {
            stimulus: lights[i % lights.len()].clone(),
            location,
            noise_seed: 7,
        })
        .collect()
}

/// The percepts of [`shows`] through the recorded run `dir` at `step`, windowed and whole-field.
fn percepts(dir: &str, step: u64) -> (Vec<f64>, Vec<f64>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (config, trainer, checkpoint) = load_run_at(&root.join(dir), step).unwrap();
    assert!(
        cortex::checkpoint::is_params_only(&checkpoint),
        "{} should be kept with its parameters only",
        checkpoint.display()
    );
    let retina = Retina::new(config.retina.clone()).unwrap();
    let windowed = EyeObserver::cortex(&retina, &trainer.cortex, config.observer.clone());
    let whole = EyeObserver::cortex(&retina, &trainer.cortex, config.observer.clone())
        .decoding_whole_field();
    let shows = shows();
    let dim = windowed.percept_dim();
    let (mut a, mut b) = (vec![0.0; shows.len() * dim], vec![0.0; shows.len() * dim]);
    windowed.percepts(&shows, &mut a);
    whole.percepts(&shows, &mut b);
    (a, b)
}

fn assert_close(a: &[f64], b: &[f64], what: &str) {
    let scale = b.iter().fold(0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0, "{what}: the percepts are all zero");
    let worst = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0f64, f64::max);
    assert!(
        worst <= 1e-5 * scale,
        "{what}: windowed and whole-field percepts differ by {worst:e} (largest value {scale:e})"
    );
}

#[test]
fn the_paper_anchor_reads_the_same_windowed_and_whole() {
    let (a, b) = percepts("results/slow-colour-anchor-paper-seed0-10k", 1000);
    assert_close(&a, &b, "paper eye, step 1 000");
}

#[test]
fn a_four_dimensional_quick_cortex_reads_the_same_windowed_and_whole() {
    let (a, b) = percepts("results/fourth-A2b-seed23", 96000);
    assert_close(&a, &b, "quick LMSQ eye, step 96 000");
}
