//! A run: simulate an eye, train the cortex on its optic nerve signal alone, measure the colour
//! dimensionality with CMF-SIM at checkpoints, and leave a run folder.
//!
//! Run folder layout:
//! - `config.toml` — the resolved settings (repeat with `--config DIR/config.toml`);
//! - `metrics.csv` — per step: loss, step time; per evaluation: held-out prediction error;
//! - `checkpoints/` — safetensors + JSON metadata with checksums, every
//!   `checkpoint_every_steps`, at each CMF-SIM measurement, at the last step and when the run
//!   is stopped by SIGINT/SIGTERM (`--resume` continues from the newest one that verifies);
//! - `cmf_sim/step_<k>/cmf_sim.json` and `.svg` — CMF-SIM at step k; the last one also at the
//!   top level (`cmf_sim.json`, with the integer field `dimension`);
//! - `pictures/` — see [`crate::pictures`];
//! - `summary.json` — `dimension`, `steps`, `wall_seconds`, the config, the dimension over steps.
//! - `report.html` — every result above on one self-contained page ([`crate::report`]).
//!
//! Resume is exact: a checkpoint holds, besides the cortex's own state, the run's state
//! ([`Progress`]: the held-out stream, the measurements so far), and `metrics.csv` is written
//! before each checkpoint, so a resumed run ends with the same parameters, metrics and
//! CMF-SIM schedule as one that never stopped (same seed, same thread count).

use crate::config::RunConfig;
use crate::interrupt;
use crate::observer::EyeObserver;
use crate::pictures;
use crate::run_folder::{self, Folder, Opened};
use crate::source::RetinaSource;
use colorimetry::cmf_sim::CmfSimSettings;
use colorimetry::plot::{LinePlot, Scale, Series};
use colorimetry::{run_cmf_sim, CmfSimResult};
use cortex::{DataSource, Trainer};
use indicatif::{ProgressBar, ProgressStyle};
use retina::Retina;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub use crate::run_error::RunError;

/// What a run does besides training.
#[derive(Clone, Copy, Debug)]
pub struct RunMode {
    /// Measure the dimension with CMF-SIM on the schedule and at the end.
    pub cmf_sim: bool,
    /// Draw pictures on the schedule and at the end.
    pub pictures: bool,
    /// Show a progress bar (hidden automatically when not a terminal).
    pub progress: bool,
}

impl RunMode {
    /// CMF-SIM, pictures and a progress bar: what `colorvision run` and the experiments do.
    pub const FULL: RunMode = RunMode {
        cmf_sim: true,
        pictures: true,
        progress: true,
    };
}

/// One CMF-SIM measurement during training.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DimensionPoint {
    /// Steps done.
    pub step: u64,
    /// Dimension measured (0: undefined).
    pub dimension: usize,
    /// Seconds CMF-SIM took.
    pub seconds: f64,
    /// Seconds since the run started, when this measurement finished.
    pub wall_seconds: f64,
    /// Primary sets per K of this measurement's budget.
    pub sets_per_k: usize,
    /// Test wavelengths of this measurement's budget.
    pub test_wavelengths: usize,
}

/// `summary.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Summary {
    /// The colour dimensionality CMF-SIM measured at the end (0 when not measured or undefined).
    pub dimension: usize,
    /// Gradient updates done.
    pub steps: u64,
    /// Steps of the checkpoints the run was resumed from, in order (empty: never stopped).
    #[serde(default)]
    pub resumed_at_steps: Vec<u64>,
    /// Wall time of the whole run (its parts, when resumed), s.
    pub wall_seconds: f64,
    /// Mean training-step time, ms.
    pub mean_step_ms: f64,
    /// Whether the cortex received the oracle eye motion.
    pub oracle_motion: bool,
    /// Dimension over training.
    pub dimension_over_steps: Vec<DimensionPoint>,
    /// First measurement of each dimension 1, 2, 3, …: `(dimension, step, seconds since the
    /// run started)`.
    pub first_step_at_dimension: Vec<(usize, u64, f64)>,
    /// Held-out prediction error at the end: `[model MSE, "next = current" MSE, ratio]`.
    pub heldout_prediction: Option<[f64; 3]>,
    /// Mean distance of the estimated eye motion from the true one on held-out batches at the
    /// end, ONS pixels (`None` with oracle motion).
    pub heldout_motion_error_px: Option<f64>,
    /// CMF-SIM verdict at the end.
    pub verdict: String,
    /// Per K tried at the end, in words: the converged margin of its reported set (see
    /// [`colorimetry::cmf_sim::KSummary::describe`]).
    pub cmf_sim_per_k: Vec<String>,
    /// Per K tried at the end: `(K, converged max error / threshold over every wavelength)`;
    /// < 1 passes.
    pub converged_ratio_per_k: Vec<(usize, f64)>,
    /// Learned invariants against the truth (evaluation only).
    pub invariants: Option<pictures::Invariants>,
    /// The resolved config.
    pub config: RunConfig,
}

/// A held-out eye: the same mosaic and layout, different scenes.
pub fn heldout_retina(config: &RunConfig) -> Result<Retina, RunError> {
    let mut c = config.retina.clone();
    c.scene_seed = c.scene_seed.wrapping_add(0x005E_ED0F_0E1D);
    Ok(Retina::new(c)?)
}

/// The last CMF-SIM measurement, as the summary reports it.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct LastMeasurement {
    /// Step measured at.
    pub step: u64,
    /// Dimension (0: undefined).
    pub dimension: usize,
    /// Verdict.
    pub verdict: String,
    /// Per K tried, the converged margin in words ([`colorimetry::cmf_sim::KSummary::describe`]).
    pub cmf_sim_per_k: Vec<String>,
    /// `(K, converged max error / threshold over every wavelength)` per K tried.
    pub converged_ratio_per_k: Vec<(usize, f64)>,
}

/// The run's own state at a checkpoint (stored in its `meta.json` as `run_state`), restored
/// on resume so the continued run is the uninterrupted one.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Progress {
    /// Whether the measurements of the checkpoint's step (CMF-SIM, pictures) are done.
    pub measured: bool,
    /// State of the held-out stream (evaluation batches, pictures).
    pub heldout_state: Option<serde_json::Value>,
    /// CMF-SIM measurements so far.
    pub dims: Vec<DimensionPoint>,
    /// The last CMF-SIM measurement.
    pub last_cmf: Option<LastMeasurement>,
    /// The last held-out prediction error.
    pub last_eval: Option<[f64; 3]>,
    /// The last held-out motion error.
    pub last_motion_error: Option<f64>,
    /// Sum of the step times, ms.
    pub step_ms_total: f64,
    /// Wall time of the run so far, s.
    pub wall_seconds: f64,
    /// Steps the run was resumed at before.
    pub resumed_at_steps: Vec<u64>,
}

/// `run.json`: what the run does besides training and where its cortex came from, so
/// `colorvision resume DIR` can continue it without its command line.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunMarker {
    /// CMF-SIM on the schedule (`run`) or not (`train`).
    pub cmf_sim: bool,
    /// Pictures on the schedule.
    pub pictures: bool,
    /// The checkpoint a continued run (gene therapy, boosting) started from.
    pub continued_from: Option<PathBuf>,
}

/// Where a run's cortex comes from.
#[derive(Clone, Copy, Debug)]
pub enum Origin<'a> {
    /// A fresh cortex.
    New,
    /// The cortex of another run's checkpoint, with Adam recreated and the step count
    /// continued (gene therapy, dimensionality boosting; authors' code, docs/references.md#training).
    Continue(&'a Path),
}

/// Trains a fresh cortex, measures and writes the run folder `out`, which must be new or
/// empty.
pub fn run(config: &RunConfig, out: &Path, mode: RunMode) -> Result<Summary, RunError> {
    run_in(config, out, mode, Folder::New, Origin::New)
}

/// Continues training the cortex of `checkpoint` on the (changed) eye of `config` for
/// `config.steps` more steps (gene therapy, dimensionality boosting; authors' code, docs/references.md#training: Adam is
/// recreated, the step count continues).
pub fn run_continued(
    config: &RunConfig,
    out: &Path,
    checkpoint: &Path,
    folder: Folder,
) -> Result<Summary, RunError> {
    run_in(
        config,
        out,
        RunMode::FULL,
        folder,
        Origin::Continue(checkpoint),
    )
}

/// A run in `out` as `folder` allows (new, resumed from its newest valid checkpoint, or
/// replaced); a finished run returns its summary. The run holds the folder's lock
/// ([`crate::run_lock`]) until it returns, so no other process trains into `out` meanwhile.
pub fn run_in(
    config: &RunConfig,
    out: &Path,
    mode: RunMode,
    folder: Folder,
    origin: Origin<'_>,
) -> Result<Summary, RunError> {
    run_folder::refuse_file(out)?;
    let _lock = crate::run_lock::RunLock::acquire(out)?;
    let opened = run_folder::open(out, config, folder)?;
    if opened == Opened::Finished {
        println!(
            "colorvision: {} holds this run, finished; its summary.json stands",
            out.display()
        );
        let path = out.join("summary.json");
        let text = std::fs::read_to_string(&path).map_err(crate::io::fs_err(&path))?;
        return serde_json::from_str(&text).map_err(|e| RunError::Folder {
            path: path.clone(),
            reason: format!("invalid summary: {e}; --force runs it again"),
        });
    }
    // The eye is built (its scene files read) before the folder is touched: bad input stops
    // the run with nothing written.
    let retina = Retina::new(config.retina.clone())?;
    let source = RetinaSource::new(retina, config.seed, config.oracle_motion);
    // Held-out batches carry the true motion for evaluation (the estimator's error); the
    // cortex reads it only when the run itself uses the oracle.
    let heldout = RetinaSource::new(heldout_retina(config)?, config.seed ^ 0xA5A5, true);
    std::fs::create_dir_all(out).map_err(crate::io::fs_err(out))?;
    for p in crate::io::clean_stale_temps(out)? {
        println!(
            "  removed a temporary left by a stopped run: {}",
            p.display()
        );
    }
    for line in cortex::checkpoint::recover(&out.join("checkpoints"))? {
        println!("  checkpoints: {line}");
    }
    if opened == Opened::Fresh {
        crate::io::write_atomic(&out.join("config.toml"), config.to_toml().as_bytes())?;
        let marker = RunMarker {
            cmf_sim: mode.cmf_sim,
            pictures: mode.pictures,
            continued_from: match origin {
                Origin::New => None,
                Origin::Continue(p) => Some(std::path::absolute(p).unwrap_or(p.to_path_buf())),
            },
        };
        crate::io::write_json(&out.join("run.json"), &marker)?;
    }
    let streams = (source, heldout);
    let state = RunState::open(config, out, mode, opened == Opened::Resume, origin, streams)?;
    state.drive()
}

/// Everything the training loop carries from step to step.
struct RunState<'a> {
    config: &'a RunConfig,
    out: &'a Path,
    mode: RunMode,
    trainer: Trainer,
    source: RetinaSource,
    heldout: RetinaSource,
    /// The training batch, refilled every step.
    batch: cortex::OnsBatch,
    progress: Progress,
    /// Finished rows of `metrics.csv` (header included).
    metrics: String,
    /// The row of the last step until its measurements add the dimension.
    pending_row: Option<String>,
    losses: (Vec<f64>, Vec<f64>),
    started: Instant,
    bar: ProgressBar,
    /// The checkpoint written last: step and whether it was after the step's measurements.
    saved: Option<(u64, bool, PathBuf)>,
}

const METRICS_HEADER: &str = "step,loss,main_loss,step_ms,heldout_model_mse,heldout_identity_mse,improvement,motion_error_px,dimension\n";

impl<'a> RunState<'a> {
    /// Steps of this run done: the trainer's steps, less those of the run it continued.
    fn run_step(&self) -> u64 {
        self.trainer.step_count() - self.trainer.continued_from_step().unwrap_or(0)
    }

    /// Builds the trainer and the streams: fresh (or continued from `origin`), or resumed from
    /// the newest checkpoint of `out` that verifies.
    fn open(
        config: &'a RunConfig,
        out: &'a Path,
        mode: RunMode,
        resume: bool,
        origin: Origin<'_>,
        (mut source, heldout): (RetinaSource, RetinaSource),
    ) -> Result<Self, RunError> {
        let resumed = if resume {
            resume_trainer(out, &mut source)?
        } else {
            None
        };
        let was_resumed = resumed.is_some();
        let (mut trainer, progress) = match resumed {
            Some(x) => x,
            None => {
                if let Origin::Continue(checkpoint) = origin {
                    println!(
                        "  continuing the cortex of {} on cones `{}`",
                        checkpoint.display(),
                        config.cones
                    );
                }
                (new_trainer(config, origin)?, Progress::default())
            }
        };
        if config.learning_rule != cortex::RuleKind::Backprop {
            let rule = learning_rule(config, &trainer, was_resumed, origin)?;
            trainer.set_learning_rule(rule);
        }
        let mut state = RunState {
            config,
            out,
            mode,
            trainer,
            source,
            heldout,
            batch: cortex::OnsBatch::default(),
            progress,
            metrics: METRICS_HEADER.to_string(),
            pending_row: None,
            losses: (Vec::new(), Vec::new()),
            started: Instant::now(),
            bar: ProgressBar::hidden(),
            saved: None,
        };
        let resumed_at = was_resumed.then(|| state.run_step());
        if resumed_at.is_some() {
            state.restore()?;
        }
        state.announce(resumed_at);
        Ok(state)
    }

    /// Puts back what the checkpoint of `step` recorded beside the trainer: the held-out
    /// stream, the clock, and `metrics.csv` up to that step.
    fn restore(&mut self) -> Result<(), RunError> {
        let step = self.run_step();
        if let Some(state) = &self.progress.heldout_state {
            self.heldout.load_state(state)?;
        }
        self.started = Instant::now()
            .checked_sub(Duration::from_secs_f64(self.progress.wall_seconds))
            .unwrap_or_else(Instant::now);
        let path = self.out.join("metrics.csv");
        let text = std::fs::read_to_string(&path).map_err(crate::io::fs_err(&path))?;
        let mut last = 0;
        for line in text.lines().skip(1) {
            let mut cols = line.split(',');
            let k: u64 = cols.next().and_then(|c| c.parse().ok()).unwrap_or(u64::MAX);
            if k > step {
                break;
            }
            if k != last + 1 {
                return Err(RunError::Folder {
                    path: path.clone(),
                    reason: format!("row of step {k} follows step {last}: the file was changed"),
                });
            }
            last = k;
            let loss: f64 = cols.next().and_then(|c| c.parse().ok()).unwrap_or(f64::NAN);
            self.losses.0.push(k as f64);
            self.losses.1.push(loss);
            self.metrics.push_str(line);
            self.metrics.push('\n');
        }
        if last != step {
            return Err(RunError::Folder {
                path,
                reason: format!("has rows up to step {last}, the checkpoint is at step {step}"),
            });
        }
        if !self.progress.measured && step > 0 {
            // The checkpoint was taken before the step's measurements: its row waits for them.
            let row_end = self.metrics[..self.metrics.len() - 1]
                .rfind('\n')
                .map_or(0, |i| i + 1);
            let row = self.metrics.split_off(row_end);
            let without_dimension = row.trim_end().rsplit_once(',').map_or("", |(r, _)| r);
            self.pending_row = Some(without_dimension.to_string());
        }
        self.progress.resumed_at_steps.push(step);
        Ok(())
    }

    fn announce(&mut self, resumed_at: Option<u64>) {
        let c = self.config;
        println!(
            "colorvision: preset `{}`, cones `{}`, seed {}, {} steps → {}",
            c.preset,
            c.cones,
            c.seed,
            c.steps,
            self.out.display()
        );
        if let Some(step) = resumed_at {
            println!(
                "  resuming at step {step} (checkpoint {})",
                self.trainer
                    .last_checkpoint()
                    .map_or_else(String::new, |p| p.display().to_string())
            );
        }
        if c.oracle_motion {
            println!("  note: the cortex receives the ORACLE eye motion (true shift) besides the optic nerve signal");
        } else {
            println!(
                "  the cortex receives the optic nerve signal only (eye motion estimated by bucket M)"
            );
        }
        if c.learning_rule != cortex::RuleKind::Backprop {
            println!("  learning rule: {}", c.learning_rule.describe());
        }
        let retina = &self.source.retina;
        println!(
            "  retina: {} cones per side, classes {:?}",
            retina.n(),
            retina
                .mosaic
                .classes
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
        );
        self.bar = if self.mode.progress {
            ProgressBar::new(c.steps)
        } else {
            ProgressBar::hidden()
        };
        self.bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .expect("a valid template")
                .progress_chars("=> "),
        );
        self.bar
            .set_position(self.trainer.step_count().min(c.steps));
    }
}

/// A fresh trainer, or one continued from another run's checkpoint: the state the run starts
/// from, the same each time it is built.
fn new_trainer(config: &RunConfig, origin: Origin<'_>) -> Result<Trainer, RunError> {
    Ok(match origin {
        Origin::New => {
            let mut cortex_config = config.cortex.clone();
            cortex_config.train.steps = config.steps;
            Trainer::new(cortex_config)?
        }
        Origin::Continue(checkpoint) => {
            Trainer::continue_from(checkpoint, Some(config.cortex.clone()))?
        }
    })
}

/// The run's learning rule, its random state drawn from the run's seed and fitted to the
/// parameters the run started from (`cortex::RuleKind::build`). A resumed run rebuilds that
/// start ([`new_trainer`]: the seeded initialisation, or the checkpoint it continued), so it
/// draws the backward weights of the run that never stopped.
fn learning_rule(
    config: &RunConfig,
    trainer: &Trainer,
    resumed: bool,
    origin: Origin<'_>,
) -> Result<Box<dyn autodiff::learn::LearningRule<f32>>, RunError> {
    let seed = config.seed ^ 0xFA;
    Ok(if resumed {
        let start = new_trainer(config, origin)?;
        config.learning_rule.build(seed, &start.cortex.params)
    } else {
        config.learning_rule.build(seed, &trainer.cortex.params)
    })
}

/// The trainer and run state of the newest checkpoint of `out` that loads (saying which
/// newer ones did not and why), or `None` when none does.
fn resume_trainer(
    out: &Path,
    source: &mut RetinaSource,
) -> Result<Option<(Trainer, Progress)>, RunError> {
    let dir = out.join("checkpoints");
    let resumed = Trainer::resume_latest(&dir, Some(source))?;
    for (path, e) in &resumed.skipped {
        println!(
            "  checkpoint {} does not load ({e}); falling back to the one before",
            path.display()
        );
    }
    let Some((trainer, meta)) = resumed.trainer else {
        println!("  no checkpoint of this run loads: starting it from the beginning");
        return Ok(None);
    };
    let progress = match meta.run_state {
        Some(v) => serde_json::from_value(v).map_err(|e| RunError::Folder {
            path: meta_path(&trainer),
            reason: format!("field `run_state`: {e}"),
        })?,
        None => Progress::default(),
    };
    Ok(Some((trainer, progress)))
}

fn meta_path(trainer: &Trainer) -> PathBuf {
    trainer
        .last_checkpoint()
        .map_or_else(PathBuf::new, |p| p.join("meta.json"))
}

impl RunState<'_> {
    /// The training loop: steps, checkpoints, measurements, and the end of the run.
    fn drive(mut self) -> Result<Summary, RunError> {
        let steps = self.config.steps;
        let mut k = self.run_step();
        if self.pending_row.is_some() && self.measure(k)? {
            return self.finish();
        }
        if self.progress.measured && self.reached_stop_dimension() {
            return self.finish();
        }
        while k < steps {
            k += 1;
            self.train_step(k)?;
            interrupt::fault_point("step", self.trainer.step_count());
            if self.checkpoint_due(k) {
                self.save(k, false)?;
            }
            self.stop_if_asked(k, false)?;
            let stop_early = self.measure(k)?;
            interrupt::fault_point("measured", self.trainer.step_count());
            self.stop_if_asked(k, true)?;
            if stop_early {
                break;
            }
        }
        self.finish()
    }

    fn cmf_due(&self, k: u64) -> bool {
        let s = &self.config.schedule;
        self.mode.cmf_sim
            && (k == self.config.steps
                || (s.cmf_every_steps > 0 && k.is_multiple_of(s.cmf_every_steps))
                || s.cmf_extra_steps.contains(&k))
    }

    fn checkpoint_due(&self, k: u64) -> bool {
        let every = self.config.cortex.train.checkpoint_every_steps;
        k == self.config.steps || (every > 0 && k.is_multiple_of(every)) || self.cmf_due(k)
    }

    fn reached_stop_dimension(&self) -> bool {
        let target = self.config.schedule.stop_at_dimension;
        target > 0
            && self
                .progress
                .dims
                .last()
                .is_some_and(|d| d.dimension >= target)
    }

    /// One gradient update and, when due, the held-out evaluation; leaves the step's metrics
    /// row pending until its measurements.
    fn train_step(&mut self, k: u64) -> Result<(), RunError> {
        let bs = self.config.cortex.train.batch_size;
        self.source.next_batch_into(bs, &mut self.batch);
        let stats = match self.trainer.step(&self.batch) {
            Ok(s) => s,
            Err(e) => {
                self.bar.abandon_with_message("stopped");
                return Err(e.into());
            }
        };
        self.progress.step_ms_total += stats.total_ms;
        self.losses.0.push(k as f64);
        self.losses.1.push(stats.loss);
        let mut row = format!(
            "{k},{},{},{:.3}",
            stats.loss, stats.main_loss, stats.total_ms
        );
        let schedule = &self.config.schedule;
        let every = schedule.eval_every_steps;
        if k == self.config.steps || (every > 0 && k.is_multiple_of(every)) {
            let batches = schedule.eval_batches;
            let e = heldout_error(&mut self.trainer, &mut self.heldout, bs, batches)?;
            self.progress.last_eval = Some(e);
            let _ = write!(row, ",{},{},{}", e[0], e[1], e[2]);
            if self.config.cortex.m.mode != cortex::config::MMode::Oracle {
                let m = heldout_motion_error(&mut self.trainer, &mut self.heldout, bs, batches)?;
                self.progress.last_motion_error = Some(m);
                let _ = write!(row, ",{m}");
            } else {
                row.push(',');
            }
        } else {
            row.push_str(",,,,");
        }
        self.pending_row = Some(row);
        self.bar.set_position(k);
        self.bar.set_message(format!(
            "loss {:.4} · {:.0} ms/step",
            stats.loss, stats.total_ms
        ));
        if self.bar.is_hidden() && k.is_multiple_of((self.config.steps / 10).max(1)) {
            // Not a terminal: a line every tenth of the run instead of a bar.
            println!(
                "  step {k}/{}: loss {:.4}, {:.0} ms/step",
                self.config.steps, stats.loss, stats.total_ms
            );
        }
        Ok(())
    }

    /// The measurements of step `k` (CMF-SIM, pictures) when due; completes its metrics row.
    /// Returns whether the run reached `stop_at_dimension`.
    fn measure(&mut self, k: u64) -> Result<bool, RunError> {
        let mut dimension_column = String::new();
        if self.cmf_due(k) {
            let final_step = k == self.config.steps;
            let settings = self.config.cmf_settings(final_step);
            self.bar.set_message(format!("step {k} · CMF-SIM…"));
            let r = measure(&settings, self.config, &self.source.retina, &self.trainer)?;
            let dir = self.out.join("cmf_sim").join(format!("step_{k:06}"));
            crate::io::save_into(&dir, |staging| -> Result<(), RunError> {
                r.save(staging)?;
                Ok(())
            })?;
            self.bar.suspend(|| {
                println!(
                    "  step {k}: CMF-SIM dimension {} ({:.0} s; {} λ, {} sets/K; {})",
                    r.dimension,
                    r.seconds,
                    settings.n_test_wavelengths,
                    settings.sets_per_k,
                    r.verdict
                )
            });
            self.progress.dims.push(DimensionPoint {
                step: k,
                dimension: r.dimension,
                seconds: r.seconds,
                wall_seconds: self.started.elapsed().as_secs_f64(),
                sets_per_k: settings.sets_per_k,
                test_wavelengths: settings.n_test_wavelengths,
            });
            dimension_column = r.dimension.to_string();
            self.progress.last_cmf = Some(LastMeasurement {
                step: k,
                dimension: r.dimension,
                verdict: r.verdict.clone(),
                cmf_sim_per_k: r
                    .per_k
                    .iter()
                    .map(|q| q.describe(r.test_wavelengths_nm.len()))
                    .collect(),
                converged_ratio_per_k: r
                    .per_k
                    .iter()
                    .map(|q| (q.n_primaries, q.converged_worst_ratio))
                    .collect(),
            });
        }
        if let Some(row) = self.pending_row.take() {
            let _ = writeln!(self.metrics, "{row},{dimension_column}");
        }
        let every = self.config.schedule.pictures_every_steps;
        if self.mode.pictures && every > 0 && k.is_multiple_of(every) && k != self.config.steps {
            pictures::write_all(
                &self.out.join("pictures").join(format!("step_{k:06}")),
                self.config,
                &self.source.retina,
                &mut self.heldout,
                &self.trainer,
            )?;
        }
        self.progress.measured = true;
        if k.is_multiple_of(200) {
            self.write_metrics()?;
        }
        let stop = self.reached_stop_dimension();
        if stop {
            let target = self.config.schedule.stop_at_dimension;
            self.bar
                .suspend(|| println!("  reached dimension {target} at step {k}: stopping early"));
        }
        Ok(stop)
    }

    fn write_metrics(&self) -> Result<(), RunError> {
        let mut text = self.metrics.clone();
        if let Some(row) = &self.pending_row {
            let _ = writeln!(text, "{row},");
        }
        crate::io::write_atomic(&self.out.join("metrics.csv"), text.as_bytes())?;
        Ok(())
    }

    /// Writes `metrics.csv`, then the checkpoint of step `k` with the run state.
    fn save(&mut self, k: u64, measured: bool) -> Result<PathBuf, RunError> {
        self.write_metrics()?;
        self.progress.measured = measured;
        self.progress.heldout_state = self.heldout.save_state();
        self.progress.wall_seconds = self.started.elapsed().as_secs_f64();
        let state = serde_json::to_value(&self.progress).expect("plain data");
        let path = self.trainer.save_checkpoint_with(
            &self.out.join("checkpoints"),
            Some(&self.source),
            Some(state),
        )?;
        self.saved = Some((k, measured, path.clone()));
        Ok(path)
    }

    /// After step `k` (before or after its measurements): when a signal asked to stop, make
    /// sure a checkpoint of this point exists and stop with [`RunError::Interrupted`].
    fn stop_if_asked(&mut self, k: u64, measured: bool) -> Result<(), RunError> {
        let Some(signal) = interrupt::requested() else {
            return Ok(());
        };
        interrupt::announce();
        let checkpoint = match &self.saved {
            Some((s, m, path)) if *s == k && *m == measured => path.clone(),
            _ => self.save(k, measured)?,
        };
        self.bar.abandon_with_message("stopped");
        Err(RunError::Interrupted {
            signal,
            step: k,
            steps: self.config.steps,
            checkpoint,
        })
    }
}

impl RunState<'_> {
    /// After the last step: plots, final pictures, the top-level CMF-SIM files, summary.json.
    fn finish(mut self) -> Result<Summary, RunError> {
        self.bar.finish_and_clear();
        let out = self.out;
        self.write_metrics()?;
        let mut loss_plot = LinePlot::new(
            "Training loss (normalised as the authors' code)",
            "step",
            "loss",
        );
        loss_plot.y.log = true;
        loss_plot.push(Series::new(
            "loss",
            std::mem::take(&mut self.losses.0),
            std::mem::take(&mut self.losses.1),
        ));
        crate::io::write_atomic(&out.join("loss.svg"), loss_plot.to_svg().as_bytes())?;
        let dims = &self.progress.dims;
        if !dims.is_empty() {
            let mut p = LinePlot::new(
                "Colour dimensionality over training (CMF-SIM)",
                "step",
                "dimension",
            );
            // An integer axis from "undefined" (0: no primary set passed) to the largest.
            p.y = Scale {
                integer: true,
                names: vec![(0.0, "undefined".into())],
                ..Scale::default()
            };
            p.x.integer = true;
            let top = dims.iter().map(|d| d.dimension).max().unwrap_or(1).max(1);
            (p.y_min, p.y_max) = (Some(-0.25), Some(top as f64 + 0.25));
            (p.x_min, p.x_max) = (Some(0.0), Some(self.config.steps as f64));
            p.push(
                Series::new(
                    "CMF-SIM dimension",
                    dims.iter().map(|d| d.step as f64).collect(),
                    dims.iter().map(|d| d.dimension as f64).collect(),
                )
                .steps(),
            );
            crate::io::write_atomic(&out.join("dimension.svg"), p.to_svg().as_bytes())?;
        }
        let invariants = if self.mode.pictures {
            Some(pictures::write_all(
                &out.join("pictures"),
                self.config,
                &self.source.retina,
                &mut self.heldout,
                &self.trainer,
            )?)
        } else {
            None
        };
        if let Some(last) = &self.progress.last_cmf {
            publish_top_level(out, last.step)?;
        }
        let summary = self.summary(invariants);
        crate::io::write_json(&out.join("summary.json"), &summary)?;
        crate::report::write(out, &summary)?;
        Ok(summary)
    }

    fn summary(&self, invariants: Option<pictures::Invariants>) -> Summary {
        let p = &self.progress;
        let mut first = Vec::new();
        for d in &p.dims {
            if d.dimension > 0 && !first.iter().any(|&(k, _, _)| k == d.dimension) {
                first.push((d.dimension, d.step, d.wall_seconds));
            }
        }
        let steps_done = self.trainer.step_count();
        let steps_here = self.run_step();
        Summary {
            dimension: p.last_cmf.as_ref().map_or(0, |r| r.dimension),
            steps: steps_done,
            resumed_at_steps: p.resumed_at_steps.clone(),
            wall_seconds: self.started.elapsed().as_secs_f64(),
            mean_step_ms: p.step_ms_total / steps_here.max(1) as f64,
            oracle_motion: self.config.oracle_motion,
            dimension_over_steps: p.dims.clone(),
            first_step_at_dimension: first,
            heldout_prediction: p.last_eval,
            heldout_motion_error_px: p.last_motion_error,
            verdict: p
                .last_cmf
                .as_ref()
                .map_or_else(|| "not measured".to_string(), |r| r.verdict.clone()),
            cmf_sim_per_k: p
                .last_cmf
                .as_ref()
                .map_or_else(Vec::new, |r| r.cmf_sim_per_k.clone()),
            converged_ratio_per_k: p
                .last_cmf
                .as_ref()
                .map_or_else(Vec::new, |r| r.converged_ratio_per_k.clone()),
            invariants,
            config: self.config.clone(),
        }
    }
}

/// Copies the files of the CMF-SIM measurement at `step` (`cmf_sim/step_<k>/`) to the top
/// of the run folder, each atomically.
fn publish_top_level(out: &Path, step: u64) -> Result<(), RunError> {
    let dir = out.join("cmf_sim").join(format!("step_{step:06}"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(crate::io::fs_err(&dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    for f in files {
        let name = f.file_name().expect("a file has a name");
        crate::io::copy_atomic(&f, &out.join(name))?;
    }
    Ok(())
}
/// CMF-SIM with `settings` on the observer "retina + the trainer's cortex".
pub fn measure(
    settings: &CmfSimSettings,
    config: &RunConfig,
    retina: &Retina,
    trainer: &Trainer,
) -> Result<CmfSimResult, RunError> {
    let observer = EyeObserver::cortex(retina, &trainer.cortex, config.observer.clone());
    Ok(run_cmf_sim(&observer, settings)?)
}

/// Held-out prediction error `[model MSE, next = current MSE, ratio]` over `batches` batches.
pub fn heldout_error(
    trainer: &mut Trainer,
    heldout: &mut RetinaSource,
    bs: usize,
    batches: usize,
) -> Result<[f64; 3], RunError> {
    let (mut model, mut identity) = (0.0, 0.0);
    for _ in 0..batches.max(1) {
        let b = heldout.next_batch(bs);
        let e = trainer.prediction_error(&b)?;
        model += e.model_mse;
        identity += e.identity_mse;
    }
    Ok([model, identity, identity / model.max(1e-30)])
}

/// Mean distance (ONS pixels) of the cortex's motion estimate from the true motion over
/// `batches` held-out batches (evaluation: the batches carry the oracle motion).
pub fn heldout_motion_error(
    trainer: &mut Trainer,
    heldout: &mut RetinaSource,
    bs: usize,
    batches: usize,
) -> Result<f64, RunError> {
    let mut total = 0.0;
    for _ in 0..batches.max(1) {
        let b = heldout.next_batch(bs);
        if let Some(e) = trainer.motion_error_ons_px(&b)? {
            total += e.mean_px;
        }
    }
    Ok(total / batches.max(1) as f64)
}

/// Prints what the run folder holds.
pub fn print_outcome(out: &Path, summary: &Summary) {
    println!();
    println!("Run folder: {}", out.display());
    println!(
        "  summary.json      dimension = {} after {} steps ({:.0} s, {:.0} ms/step)",
        summary.dimension, summary.steps, summary.wall_seconds, summary.mean_step_ms
    );
    if let Some([m, i, r]) = summary.heldout_prediction {
        println!("  held-out prediction error {m:.4e} vs {i:.4e} for \"next frame = this frame\" ({r:.1}× better)");
    }
    if let Some(m) = summary.heldout_motion_error_px {
        println!("  motion estimate vs true motion on held-out batches: mean error {m:.2} ONS px");
    }
    if let Some(inv) = &summary.invariants {
        let axis = |a: &Option<colorimetry::HueAxis>| match a {
            Some(a) => format!("{:.0}° (minor/major {:.2})", a.angle_deg, a.minor_to_major),
            None => "none".into(),
        };
        println!("  learned invariants against the eye's truth:");
        for line in inv.recovery.describe() {
            println!("    {line}");
        }
        println!(
            "  Neural-Scope hue axis {} (scenes: {})",
            axis(&inv.scope_hue_axis),
            axis(&inv.truth_hue_axis),
        );
    }
    for (d, s, t) in &summary.first_step_at_dimension {
        println!("  first measured {d}-D at step {s} ({t:.0} s into the run)");
    }
    println!(
        "  cmf_sim.json/svg  CMF-SIM errors per wavelength for 0..K primaries; {}",
        summary.verdict
    );
    for line in &summary.cmf_sim_per_k {
        println!("    {line}");
    }
    println!("  dimension.svg     dimension over training;  loss.svg  training loss");
    println!("  pictures/         ONS, Neural-Scope percept beside the truth, learned C, P positions, W kernel");
    println!("  metrics.csv, checkpoints/, config.toml");
}

/// The run folder for `config` and an optional `--out`.
pub fn out_dir(config: &RunConfig, out: Option<&PathBuf>, command: &str) -> PathBuf {
    out.cloned().unwrap_or_else(|| config.default_out(command))
}
