//! One training step at `quick` and `paper` (`cargo bench --bench cortex_step [quick|paper]
//! [--profile]`).
//!
//! Targets: the whole quick step, retina batch included, ≤ 61 ms (anchor: PyTorch
//! 2.15 CPU, 2 threads, a 16/32/64 U-Net alone, forward + backward + Adam at batch 8, 64²).
//! `quick` measures what `colorvision train` does per step — draw a batch from the LMS retina,
//! then the cortex step (motion estimation, forward, backward, Adam) — for the quick preset
//! with block-matching motion, the quick preset with the oracle motion (what the default run
//! uses) and the sandbox preset, **interleaved step by step** so that the three see the same
//! machine load (a shared VM's speed can drift by tens of per cent over minutes). `rules` runs
//! the default quick step (oracle motion) under each learning rule (`cortex::rule::BUILT_IN`),
//! interleaved the same way, and prints each rule's cortex step relative to backprop's (only when
//! named: `cargo bench --bench cortex_step -- rules`). `paper` runs the
//! paper cortex on a synthetic batch (its retina is benchmarked in `benches/retina.rs`), with
//! the oracle motion (as `--preset paper` runs train) and with block-matching motion.
//! Paper step: report time and peak memory (target ≤ 8 GiB).
//!
//! Output: median whole step, batch and cortex times over the timed steps, the median
//! per-bucket split (forward + backward per bucket W, C, D, P, M, loss; Adam separately), and
//! with `--profile` the per-op table of the tape profiler (adds ≈ 50 ns per op). Peak memory
//! is the process's high-water mark of resident memory (`VmHWM` in /proc/self/status) after
//! the paper steps. Plain timing loop (no criterion): a training step mutates the model, and
//! the split per bucket is the point.

use cortex::config::{CortexConfig, MMode};
use cortex::model::{BUCKETS, BUCKET_NAMES};
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{DataSource, OnsBatch, StepStats, Trainer};
use retina::Retina;
use science::source::RetinaSource;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// One configuration under measurement: its trainer, its data source and what it took.
struct Case {
    name: &'static str,
    trainer: Trainer,
    source: Box<dyn DataSource>,
    /// The batch, refilled every step as the run does.
    batch: OnsBatch,
    /// Milliseconds to draw each timed batch from the source.
    batch_ms: Vec<f64>,
    /// Whether the source is the retina (its time counts in the whole step) or a synthetic
    /// stand-in (reported apart).
    retina: bool,
    stats: Vec<StepStats>,
}

impl Case {
    fn new(
        name: &'static str,
        cfg: CortexConfig,
        source: Box<dyn DataSource>,
        retina: bool,
    ) -> Self {
        Case {
            name,
            retina,
            trainer: Trainer::new(cfg).expect("preset is valid"),
            source,
            batch: OnsBatch::default(),
            batch_ms: Vec::new(),
            stats: Vec::new(),
        }
    }

    /// The same case trained by the built-in rule `rule` with its default settings (random
    /// state from seed 1).
    fn with_rule(mut self, rule: &str) -> Self {
        let built = cortex::rule::with_defaults(rule, 1, &self.trainer.cortex.params)
            .expect("a built-in rule");
        self.trainer
            .set_learning_rule(built)
            .expect("a fresh trainer");
        self
    }

    /// Median cortex step, ms.
    fn cortex_ms(&self) -> f64 {
        median(self.stats.iter().map(|s| s.total_ms).collect())
    }

    /// One training step as `colorvision train` runs it: draw a batch, then step.
    fn step(&mut self, timed: bool, profile: bool) {
        let bs = self.trainer.config().train.batch_size;
        self.trainer.set_profiling(profile && timed);
        let t0 = std::time::Instant::now();
        self.source.next_batch_into(bs, &mut self.batch);
        let batch_ms = t0.elapsed().as_secs_f64() * 1e3;
        let s = self.trainer.step(&self.batch).expect("step");
        if timed {
            self.batch_ms.push(batch_ms);
            self.stats.push(s);
        }
    }

    fn report(&mut self, profile: bool) {
        let (stats, timed) = (&self.stats, self.stats.len());
        let cortex = median(stats.iter().map(|s| s.total_ms).collect());
        let whole = median(
            stats
                .iter()
                .zip(&self.batch_ms)
                .map(|(s, b)| s.total_ms + b)
                .collect(),
        );
        let batch = median(self.batch_ms.clone());
        let head = match self.retina {
            true => {
                format!("median whole step {whole:.1} ms = batch {batch:.1} + cortex {cortex:.1}")
            }
            false => format!(
                "median cortex step {cortex:.1} ms (synthetic batch {batch:.0} ms, not counted)"
            ),
        };
        println!(
            "{}: n = {}, batch {}, {} params; {head} (medians of {timed} steps; loss {:.4} → {:.4})",
            self.name,
            self.trainer.config().ons_size_px,
            self.trainer.config().train.batch_size,
            self.trainer.cortex.params.numel(),
            stats[0].loss,
            stats[timed - 1].loss
        );
        let mut line = String::new();
        for (i, name) in BUCKET_NAMES.iter().enumerate().take(BUCKETS) {
            let f = median(stats.iter().map(|s| s.forward_ms[i]).collect());
            let b = median(stats.iter().map(|s| s.backward_ms[i]).collect());
            line.push_str(&format!("{name} {f:.1}+{b:.1}  "));
        }
        let adam = median(stats.iter().map(|s| s.optimizer_ms).collect());
        let credit = median(stats.iter().map(|s| s.credit_ms).collect());
        println!(
            "  per bucket, forward+backward ms: {line}adam {adam:.1}  (whole backward {credit:.1})"
        );
        if profile {
            let p = self.trainer.take_profile().scaled(1.0 / timed as f64);
            println!("  per op, ms per step (calls over all {timed} steps):\n{p}");
        }
    }
}

/// Runs the cases' steps interleaved (one step of each in turn), so that every case sees the
/// same machine load, then reports each.
fn bench(mut cases: Vec<Case>, warmup: usize, timed: usize, profile: bool) {
    for k in 0..warmup + timed {
        for case in &mut cases {
            case.step(k >= warmup, profile);
        }
    }
    for case in &mut cases {
        case.report(profile);
    }
}

/// The retina of `preset` (LMS) as a training data source, with the oracle motion if asked.
fn retina_source(preset: &str, oracle_motion: bool) -> Box<dyn DataSource> {
    let retina = Retina::preset(preset, "LMS").expect("retina preset");
    Box::new(RetinaSource::new(retina, 1, oracle_motion))
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let want = |p: &str| args.is_empty() || args.iter().any(|a| a == p);
    let profile = std::env::args().any(|a| a == "--profile");
    println!("rayon threads: {}", rayon::current_num_threads());
    if want("quick") {
        // The whole step, retina batch included (the target above), three presets in turn.
        let mut oracle = CortexConfig::quick();
        oracle.m.mode = MMode::Oracle;
        let cases = vec![
            Case::new(
                "quick (block-matching motion)",
                CortexConfig::quick(),
                retina_source("quick", false),
                true,
            ),
            Case::new(
                "quick, oracle motion (the default run)",
                oracle,
                retina_source("quick", true),
                true,
            ),
            Case::new(
                "sandbox",
                CortexConfig::sandbox(),
                retina_source("sandbox", true),
                true,
            ),
        ];
        bench(cases, 3, 30, profile);
    }
    if args.iter().any(|a| a == "rules") {
        let mut oracle = CortexConfig::quick();
        oracle.m.mode = MMode::Oracle;
        let mut cases: Vec<Case> = cortex::rule::BUILT_IN
            .iter()
            .map(|&rule| {
                Case::new(rule, oracle.clone(), retina_source("quick", true), true).with_rule(rule)
            })
            .collect();
        for k in 0..3 + 20 {
            for case in &mut cases {
                case.step(k >= 3, false);
            }
        }
        let base = cases[0].cortex_ms();
        for case in &mut cases {
            case.report(false);
            println!(
                "  cortex step relative to backprop: {:.2}×",
                case.cortex_ms() / base
            );
        }
    }
    if want("paper") {
        // The paper cortex on a synthetic batch (its retina is benchmarked in `benches/retina.rs`),
        // with the oracle motion (what `--preset paper` runs use, and PyTorch's port) and with
        // block matching (`CortexConfig::paper`'s own M: motion estimation and P's gauge term).
        let mut oracle = CortexConfig::paper();
        oracle.m.mode = MMode::Oracle;
        let synthetic = |cfg: &CortexConfig| {
            Box::new(SyntheticSource::new(SyntheticConfig::lms(
                cfg.ons_size_px,
                1,
            )))
        };
        let block_matching = CortexConfig::paper();
        let cases = vec![
            Case::new("paper", oracle.clone(), synthetic(&oracle), false),
            Case::new(
                "paper (block-matching motion)",
                block_matching.clone(),
                synthetic(&block_matching),
                false,
            ),
        ];
        bench(cases, 1, 3, profile);
        if let Some(mib) = peak_rss_mib() {
            println!("  peak resident memory of the process after the paper steps: {mib:.0} MiB");
        }
    }
}
