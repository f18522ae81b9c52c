//! A run: simulate an eye, train the cortex on its optic nerve signal alone, measure the colour
//! dimensionality with CMF-SIM at checkpoints, and leave a run folder.
//!
//! Run folder layout:
//! - `config.toml` — the resolved settings (repeat with `--config DIR/config.toml`);
//! - `metrics.csv` — per step: loss, step time; per evaluation: held-out prediction error;
//!   per alignment measurement: the learning rule against backprop, per bucket
//!   ([`crate::alignment_plot`]);
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
//! CMF-SIM schedule as one that never stopped (same seed, same thread count; the checkpoint
//! records the count, and a resume with another one says so before its first step).

use crate::interrupt;
use crate::pictures;
use colorimetry::cmf_sim::CmfSimSettings;
use colorimetry::plot::{LinePlot, Scale, Series};
use colorimetry::CmfSimResult;
use cortex::{DataSource, Trainer};
use folder::{Folder, Opened};
use indicatif::{ProgressBar, ProgressStyle};
use retina::Retina;
use science::config::RunConfig;
use science::heldout::{heldout_error, heldout_motion_error, heldout_source_until};
use science::observer::EyeObserver;
use science::source::RetinaSource;
use science::summary::{margins_text, DimensionPoint, LastMeasurement, Summary};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub mod error;
mod finish;
pub mod folder;
pub mod lock;
pub mod measurement_dir;
mod open;
mod steps;
pub mod temporaries;

pub use error::RunError;
pub use finish::{in_words, out_dir, print_outcome};
pub use open::start_w_at_the_eyes_kernel;
pub use steps::measure;

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
    /// Worker threads (`RAYON_NUM_THREADS`) when the checkpoint was written; `None` in
    /// checkpoints written before the count was recorded.
    #[serde(default)]
    pub threads: Option<usize>,
    /// The CPU's instruction set when the checkpoint was written
    /// ([`crate::instruction_set::current`]); `None` in checkpoints written before it was
    /// recorded.
    #[serde(default)]
    pub instruction_set: Option<String>,
}

/// `run.json`: what the run does besides training and where its cortex came from, so
/// `colorvision resume DIR` can continue it without its command line.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunMarker {
    /// CMF-SIM on the schedule (`run`) or not (`train`).
    pub cmf_sim: bool,
    /// Pictures on the schedule.
    pub pictures: bool,
    /// The checkpoint a continued run (gene therapy, boosting) started from, relative to the
    /// run folder (a run and the run it continues move together); records name it from the
    /// repository root, and markers of older versions by its absolute path
    /// ([`RunMarker::origin_checkpoint`] reads all three).
    pub continued_from: Option<PathBuf>,
}

impl RunMarker {
    /// The marker of a run in `out` with `mode`, its cortex from `origin`.
    fn new(mode: RunMode, origin: Origin<'_>, out: &Path) -> RunMarker {
        RunMarker {
            cmf_sim: mode.cmf_sim,
            pictures: mode.pictures,
            continued_from: match origin {
                Origin::New => None,
                Origin::Continue(p) => Some(relative_path(out, p)),
            },
        }
    }

    /// The checkpoint the run in `dir` was continued from: `continued_from` taken from the run
    /// folder where it names something there, else as written (an absolute path, or a
    /// record's path from the repository root). `None` for a fresh cortex.
    pub fn origin_checkpoint(&self, dir: &Path) -> Option<PathBuf> {
        let p = self.continued_from.as_ref()?;
        let from_run = dir.join(p);
        Some(if p.is_relative() && from_run.exists() {
            from_run
        } else {
            p.clone()
        })
    }
}

/// `to` named from folder `from`: both made absolute and their `.` and `..` resolved by name,
/// then `..` for each of `from`'s own components below what they share.
pub fn relative_path(from: &Path, to: &Path) -> PathBuf {
    use std::path::Component;
    let resolved = |p: &Path| -> Vec<std::ffi::OsString> {
        let mut parts = Vec::new();
        for c in std::path::absolute(p)
            .unwrap_or(p.to_path_buf())
            .components()
        {
            match c {
                Component::ParentDir => {
                    parts.pop();
                }
                Component::Normal(n) => parts.push(n.to_os_string()),
                Component::CurDir | Component::RootDir | Component::Prefix(_) => {}
            }
        }
        parts
    };
    let (from, to) = (resolved(from), resolved(to));
    let shared = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    let mut out: PathBuf = std::iter::repeat_n("..", from.len() - shared).collect();
    out.extend(&to[shared..]);
    out
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

/// Environment variable: the memory a run may take, MiB (0: no limit). Unset, the limit is
/// [`science::budget::LIMIT_FRACTION`] of the cgroup's limit or of the available memory.
pub const MEMORY_LIMIT_VAR: &str = "COLORVISION_MEMORY_LIMIT_MIB";

/// Estimates the run's peak memory from its settings ([`science::budget`]), says it, and
/// refuses the run, before anything is allocated or written, when it exceeds the limit.
pub fn check_memory(config: &RunConfig, mode: RunMode) -> Result<(), RunError> {
    let estimate = science::budget::estimate(config, mode.cmf_sim, rayon::current_num_threads());
    check_estimate(&if mode.pictures {
        estimate
    } else {
        science::budget::without_pictures(config, estimate)
    })
}

/// Says `estimate` and refuses, before anything is allocated or written, when it exceeds the
/// limit ([`MEMORY_LIMIT_VAR`], else a share of the memory there is).
pub fn check_estimate(estimate: &science::budget::Estimate) -> Result<(), RunError> {
    let mib = 1024.0 * 1024.0;
    let (limit, source) = match std::env::var(MEMORY_LIMIT_VAR) {
        Ok(v) => {
            let given: f64 = v
                .trim()
                .parse()
                .ok()
                .filter(|m: &f64| m.is_finite() && *m >= 0.0)
                .ok_or_else(|| {
                    RunError::invalid(
                        MEMORY_LIMIT_VAR,
                        format!(
                            "`{}` is not a number of MiB",
                            science::config::shortened(&v)
                        ),
                    )
                })?;
            let limit = if given == 0.0 {
                f64::INFINITY
            } else {
                given * mib
            };
            (limit, format!("{MEMORY_LIMIT_VAR}={v}"))
        }
        Err(_) => match science::budget::memory_available() {
            Some((bytes, what)) => (
                science::budget::LIMIT_FRACTION * bytes,
                format!("{:.0} % of {what}", 100.0 * science::budget::LIMIT_FRACTION),
            ),
            None => (f64::INFINITY, "none known".to_string()),
        },
    };
    println!(
        "  memory: estimated peak {:.0} MiB (limit {})",
        estimate.total_bytes() / mib,
        if limit.is_finite() {
            format!("{:.0} MiB, {source}", limit / mib)
        } else {
            "none".to_string()
        }
    );
    science::budget::check(estimate, limit, &source)?;
    Ok(())
}

/// A run in `out` as `folder` allows (new, resumed from its newest valid checkpoint, or
/// replaced); a finished run returns its summary. The run holds the folder's lock
/// ([`crate::run::lock`]) until it returns, so no other process trains into `out` meanwhile.
pub fn run_in(
    config: &RunConfig,
    out: &Path,
    mode: RunMode,
    folder: Folder,
    origin: Origin<'_>,
) -> Result<Summary, RunError> {
    folder::refuse_file(out)?;
    check_memory(config, mode)?;
    let _lock = lock::RunLock::acquire(out)?;
    let opened = folder::open(out, config, folder)?;
    if opened == Opened::Finished {
        temporaries::remove_stale_temporaries(out)?;
        println!(
            "colorvision: {} holds this run, finished; its summary.json stands",
            out.display()
        );
        let path = out.join("summary.json");
        let summary = Summary::read(&path).map_err(|e| RunError::Folder {
            path: path.clone(),
            reason: format!("invalid summary: {e}; --force runs it again"),
        })?;
        // The report is written after summary.json: a run stopped between them gets it now. A
        // record (`results/NAME`, `record.json`) keeps what `scripts/record-run.sh` copied.
        if !out.join(crate::report::REPORT_FILE).is_file() && !out.join("record.json").is_file() {
            crate::report::write(out, &summary)?;
            println!("  wrote the report the stopped run had not written");
        }
        return Ok(summary);
    }
    // The eye is built (its scene files read) before the folder is touched: bad input stops
    // the run with nothing written.
    let eyes = || -> Result<(RetinaSource, RetinaSource), RunError> {
        let retina = crate::scene_bar::retina(config.retina.clone())?;
        let source = RetinaSource::new(retina, config.seed, config.oracle_motion);
        // Held-out batches carry the true motion for evaluation (the estimator's error); the
        // cortex reads it only when the run itself uses the oracle.
        let heldout = heldout_source_until(config, true, interrupt::stop_flag())?;
        Ok((source, heldout))
    };
    interrupt::during("scene generation", "the run folder was not touched");
    let (source, heldout) =
        eyes().map_err(|e| e.said_as_stop(|| "the run folder was not touched".into()))?;
    std::fs::create_dir_all(out).map_err(crate::io::fs_err(out))?;
    temporaries::remove_stale_temporaries(out)?;
    for line in cortex::checkpoint::recover(&out.join("checkpoints"))? {
        println!("  checkpoints: {line}");
    }
    // The marker first, `config.toml` second (`folder::MARKER_FILE`): a start stopped between
    // them leaves a folder a run starts afresh in. A resumed folder without its marker (a
    // start stopped between them by an older version) gets it now, so `resume` reads it.
    let marker_path = out.join(folder::MARKER_FILE);
    if opened == Opened::Fresh || !marker_path.is_file() {
        crate::io::write_json(&marker_path, &RunMarker::new(mode, origin, out))?;
    }
    if opened == Opened::Fresh {
        crate::io::write_atomic(&out.join("config.toml"), config.to_toml().as_bytes())?;
    }
    interrupt::during(
        "the start of the run",
        format!(
            "no step is recorded yet. Continue with `colorvision resume {}` (or the same \
             command with --resume)",
            out.display()
        ),
    );
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
    /// Whether this process has said that a step's warp mask was empty (said once per
    /// process: again after a resume).
    said_empty_warp: bool,
}

/// `metrics.csv`'s header: the step's loss and time, the held-out evaluation, the learning
/// rule against backprop ([`crate::alignment_plot`]), the CMF-SIM dimension (always last).
const METRICS_HEADER: &str = concat!(
    "step,loss,main_loss,step_ms,heldout_model_mse,heldout_identity_mse,improvement,",
    "motion_error_px,",
    "align_cos_W,align_cos_C,align_cos_D,align_cos_P,",
    "rule_norm_W,rule_norm_C,rule_norm_D,rule_norm_P,",
    "backprop_norm_W,backprop_norm_C,backprop_norm_D,backprop_norm_P,",
    "dimension\n"
);

#[cfg(test)]
mod tests;
