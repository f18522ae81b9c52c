//! One cortex training step under each learning rule (criterion;
//! `cargo bench --bench learning_rules`).
//!
//! `learning_rule_step/<rule>`: the default run's step — the `quick` cortex with the oracle
//! eye motion — on one fixed batch of 8 drawn from the quick LMS retina, under backprop,
//! feedback alignment, direct feedback alignment and forward-forward (`cortex::rule::BUILT_IN`):
//! motion, forward, the rule's gradients, Adam. The batch is drawn once, so only the cortex
//! step is timed. Each rule's cost relative to backprop is the ratio of the medians (criterion
//! writes them to `target/criterion/learning_rule_step/*/new/estimates.json`).
//!
//! A step changes the model; a rule whose parameters stop being finite (feedback alignment
//! and direct feedback alignment can run away on this eye) gets a fresh trainer outside the
//! timed part, so every timed step is an ordinary step of that rule. The benchmarks run one
//! after another: on a machine whose load drifts, compare ratios from one run, or use the
//! interleaved `cargo bench --bench cortex_step -- rules`.

use cortex::config::{CortexConfig, MMode};
use cortex::{DataSource, OnsBatch, Trainer};
use criterion::{criterion_group, criterion_main, Criterion};
use retina::Retina;
use science::source::RetinaSource;
use std::time::{Duration, Instant};

/// The default run's cortex (quick, oracle motion) trained by `rule` (its random state from
/// seed 1).
fn trainer(rule: &str) -> Trainer {
    let mut config = CortexConfig::quick();
    config.m.mode = MMode::Oracle;
    let mut trainer = Trainer::new(config).expect("the quick preset is valid");
    let built = cortex::rule::with_defaults(rule, 1, &trainer.cortex.params).expect("a rule");
    trainer.set_learning_rule(built).expect("a fresh trainer");
    trainer
}

/// One batch of the quick LMS retina with the oracle motion.
fn batch(size: usize) -> OnsBatch {
    let retina = Retina::preset("quick", "LMS").expect("retina preset");
    RetinaSource::new(retina, 1, true).next_batch(size)
}

fn learning_rule_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("learning_rule_step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(3))
        .measurement_time(Duration::from_secs(20));
    let batch = batch(CortexConfig::quick().train.batch_size);
    for rule in cortex::rule::BUILT_IN {
        let mut t = trainer(rule);
        group.bench_function(rule, |b| {
            b.iter_custom(|iters| {
                let mut timed = Duration::ZERO;
                for _ in 0..iters {
                    let start = Instant::now();
                    let stepped = t.step(&batch);
                    timed += start.elapsed();
                    if stepped.is_err() {
                        t = trainer(rule);
                    }
                }
                timed
            })
        });
    }
    group.finish();
}

criterion_group!(benches, learning_rule_step);
criterion_main!(benches);
