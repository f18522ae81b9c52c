//! One cortex training step at `quick` and `paper` (`cargo bench --bench cortex_step [quick|paper]
//! [--profile]`).
//!
//! Targets (issue 4): the whole quick step, retina batch included, ≤ 61 ms (anchor: PyTorch
//! 2.15 CPU, 2 threads, a 16/32/64 U-Net alone, forward + backward + Adam at batch 8, 64²);
//! this bench measures the **cortex part** (motion estimation, forward, backward, Adam) on a
//! pre-generated synthetic batch, the retina's share is benchmarked in `benches/retina.rs`.
//! Paper step: report time and peak memory (target ≤ 8 GiB).
//!
//! Output: median step time over the timed steps, and the median per-bucket split (forward +
//! backward per bucket W, C, D, P, M, loss; Adam separately). Peak memory is the process's
//! high-water mark of resident memory (`VmHWM` in /proc/self/status) after the paper steps.
//! Plain timing loop (no criterion): a training step mutates the model, and the split per
//! bucket is the point.

use cortex::config::{CortexConfig, MMode};
use cortex::model::{BUCKETS, BUCKET_NAMES};
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{DataSource, StepStats, Trainer};

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

fn bench(name: &str, cfg: CortexConfig, warmup: usize, timed: usize) {
    let n = cfg.ons_size_px;
    let bs = cfg.train.batch_size;
    let mut src = SyntheticSource::new(SyntheticConfig::lms(n, 1));
    let t0 = std::time::Instant::now();
    let batch = src.next_batch(bs);
    let gen_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut trainer = Trainer::new(cfg).expect("preset is valid");
    let mut stats: Vec<StepStats> = Vec::new();
    let profile = std::env::args().any(|a| a == "--profile");
    for k in 0..warmup + timed {
        trainer.set_profiling(profile && k >= warmup);
        let s = trainer.step(&batch).expect("step");
        if k >= warmup {
            stats.push(s);
        }
    }
    let total = median(stats.iter().map(|s| s.total_ms).collect());
    println!(
        "{name}: n = {n}, batch {bs}, {} params; median step {total:.1} ms over {timed} steps (loss {:.4} → {:.4}); synthetic batch generation {gen_ms:.0} ms (not included)",
        trainer.cortex.params.numel(),
        stats[0].loss,
        stats[stats.len() - 1].loss
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
        let p = trainer.take_profile().scaled(1.0 / timed as f64);
        println!("  per op, ms per step (calls over all {timed} steps):\n{p}");
    }
}

fn main() {
    // `--profile`: also print the per-op table of the tape profiler (adds ≈ 50 ns per op).
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let want = |p: &str| args.is_empty() || args.iter().any(|a| a == p);
    println!("rayon threads: {}", rayon::current_num_threads());
    if want("quick") {
        bench("quick", CortexConfig::quick(), 3, 15);
        // The default `colorvision run` gives the quick cortex the oracle motion (M costs nothing).
        let mut oracle = CortexConfig::quick();
        oracle.m.mode = MMode::Oracle;
        bench("quick, oracle motion (the default run)", oracle, 3, 15);
        bench("sandbox", CortexConfig::sandbox(), 3, 15);
    }
    if want("paper") {
        bench("paper", CortexConfig::paper(), 1, 3);
        if let Some(mib) = peak_rss_mib() {
            println!("  peak resident memory of the process after the paper steps: {mib:.0} MiB");
        }
    }
}
