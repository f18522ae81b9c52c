//! Measuring a cortex from your own code, with no command line: the `tiny` eye's cortex trained
//! a few steps on the eye's optic nerve signal, then the black-box observer "retina + cortex"
//! built and measured — CMF-SIM, the learned invariants against the eye's truth, the held-out
//! prediction — and CMF-SIM checked on an observer whose answer is known: the oracle decoder of
//! the same LMS eye reads three colour dimensions.
//!
//! `cargo run --release -p science --example tiny_eye`; `cargo test` runs it as a test.

use cortex::{DataSource, OnsBatch, Trainer};
use retina::Retina;
use science::config::RunConfig;
use science::heldout::{heldout_error, heldout_source};
use science::measure::measure_observer;
use science::observer::ObserverKind;
use science::source::RetinaSource;

/// Gradient updates of the cortex: enough to show the loop, far too few for colour.
const STEPS: u64 = 20;

/// Held-out batches behind the prediction error.
const HELD_OUT_BATCHES: usize = 2;

fn main() -> Result<(), science::Error> {
    let config = RunConfig::preset("tiny", "LMS")?;
    // The eye feeds the cortex its optic nerve signal (with the oracle eye motion, as the
    // `tiny` preset says); the cortex never sees the eye's truth.
    let retina = Retina::new(config.retina.clone())?;
    let mut source = RetinaSource::new(retina, config.seed, config.oracle_motion);
    let mut trainer = Trainer::new(config.cortex.clone())?;
    let batch_size = config.cortex.train.batch_size;
    let mut batch = OnsBatch::default();
    for _ in 0..STEPS {
        source.next_batch_into(batch_size, &mut batch);
        let stats = trainer.step(&batch)?;
        if stats.step % 5 == 0 {
            println!("step {:>2}: loss {:.4}", stats.step, stats.loss);
        }
    }

    // The trained cortex as a colour observer, and CMF-SIM on it.
    let learned = measure_observer(&config, ObserverKind::Cortex, Some(&trainer))?;
    println!(
        "CMF-SIM, the cortex after {STEPS} steps: {}",
        learned.verdict
    );
    // What it learned of the eye, against the eye's truth (evaluation only).
    for line in science::invariants::measure(&trainer.cortex, &source.retina).describe() {
        println!("  {line}");
    }
    let mut held_out = heldout_source(&config, true)?;
    let never = std::sync::atomic::AtomicBool::new(false);
    let [model, no_change, gain] = heldout_error(
        &mut trainer,
        &mut held_out,
        batch_size,
        HELD_OUT_BATCHES,
        &never,
    )?;
    println!(
        "held-out prediction: error {model:.3e} against {no_change:.3e} for \"next frame = this \
         frame\" ({gain:.2}×)"
    );

    // The known answer: the oracle decoder of the same eye has three colour dimensions.
    let oracle = measure_observer(&config, ObserverKind::Oracle, None)?;
    println!(
        "CMF-SIM, the oracle decoder of the LMS eye: {}",
        oracle.verdict
    );
    assert_eq!(
        oracle.dimension, 3,
        "the oracle decoder of an LMS eye reads 3: {}",
        oracle.verdict
    );
    Ok(())
}

#[test]
fn the_tiny_eye_is_measured_and_its_oracle_decoder_reads_three() {
    main().expect("the tiny eye is trained and measured");
}
