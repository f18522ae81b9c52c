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

mod finish;
mod open;
mod steps;

pub use finish::{digits_grouped, in_words, out_dir, print_outcome};
pub use open::start_w_at_the_eyes_kernel;
pub use steps::{heldout_error, heldout_motion_error, measure};

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
fn heldout_retina(config: &RunConfig) -> Result<Retina, RunError> {
    let mut c = config.retina.clone();
    c.scene_seed = c.scene_seed.wrapping_add(0x005E_ED0F_0E1D);
    Ok(Retina::new(c)?)
}

/// The run's held-out batches (the held-out eye, its own batch seed), the same sequence on
/// every call; with `true_motion` each batch carries the eye's motion for evaluation.
pub fn heldout_source(config: &RunConfig, true_motion: bool) -> Result<RetinaSource, RunError> {
    Ok(RetinaSource::new(
        heldout_retina(config)?,
        config.seed ^ 0xA5A5,
        true_motion,
    ))
}

/// CMF-SIM's margins in short, e.g. "K1 4.54, K2 1.02, K3 0.99": per K tried, the reported
/// set's worst error over every test wavelength in units of the threshold (above 1 fails,
/// below 1 passes).
pub fn margins_text(converged_ratio_per_k: &[(usize, f64)]) -> String {
    converged_ratio_per_k
        .iter()
        .map(|(k, r)| format!("K{k} {r:.2}"))
        .collect::<Vec<_>>()
        .join(", ")
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

impl LastMeasurement {
    /// What the CMF-SIM result `r`, measured at `step`, reports.
    pub fn of(step: u64, r: &CmfSimResult) -> Self {
        LastMeasurement {
            step,
            dimension: r.dimension,
            verdict: r.verdict.clone(),
            cmf_sim_per_k: (r.per_k.iter())
                .map(|q| q.describe(r.test_wavelengths_nm.len()))
                .collect(),
            converged_ratio_per_k: (r.per_k.iter())
                .map(|q| (q.n_primaries, q.converged_worst_ratio))
                .collect(),
        }
    }
}

impl Summary {
    /// Reads `summary.json` at `path`; the error in words.
    pub fn read(path: &Path) -> Result<Summary, String> {
        crate::io::read_json(path)
    }

    /// The summary of an observer measured without training (S-05's Φ = identity baselines):
    /// no step done, one CMF-SIM measurement `r` with `config.cmf_sim`, no learned invariants.
    pub fn untrained(config: &RunConfig, r: &CmfSimResult) -> Summary {
        let measured = LastMeasurement::of(0, r);
        Summary {
            dimension: r.dimension,
            steps: 0,
            resumed_at_steps: Vec::new(),
            wall_seconds: r.seconds,
            mean_step_ms: 0.0,
            oracle_motion: config.oracle_motion,
            dimension_over_steps: vec![DimensionPoint {
                step: 0,
                dimension: r.dimension,
                seconds: r.seconds,
                wall_seconds: r.seconds,
                sets_per_k: config.cmf_sim.sets_per_k,
                test_wavelengths: config.cmf_sim.n_test_wavelengths,
            }],
            first_step_at_dimension: match r.dimension {
                0 => Vec::new(),
                d => vec![(d, 0, r.seconds)],
            },
            heldout_prediction: None,
            heldout_motion_error_px: None,
            verdict: measured.verdict,
            cmf_sim_per_k: measured.cmf_sim_per_k,
            converged_ratio_per_k: measured.converged_ratio_per_k,
            invariants: None,
            config: config.clone(),
        }
    }
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
        return Summary::read(&path).map_err(|e| RunError::Folder {
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
    let heldout = heldout_source(config, true)?;
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
