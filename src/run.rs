//! A run: simulate an eye, train the cortex on its optic nerve signal alone, measure the colour
//! dimensionality with CMF-SIM at checkpoints, and leave a run folder.
//!
//! Run folder layout:
//! - `config.toml` — the resolved settings (repeat with `--config DIR/config.toml`);
//! - `metrics.csv` — per step: loss, step time; per evaluation: held-out prediction error;
//! - `checkpoints/` — safetensors + JSON metadata (resume with the cortex's `Trainer::resume`);
//! - `cmf_sim/step_<k>/cmf_sim.json` and `.svg` — CMF-SIM at step k; the last one also at the
//!   top level (`cmf_sim.json`, with the integer field `dimension`);
//! - `pictures/` — see [`crate::pictures`];
//! - `summary.json` — `dimension`, `steps`, `wall_seconds`, the config, the dimension over steps.

use crate::config::RunConfig;
use crate::observer::EyeObserver;
use crate::pictures;
use crate::source::RetinaSource;
use colorimetry::cmf_sim::CmfSimSettings;
use colorimetry::plot::{LinePlot, Series};
use colorimetry::{run_cmf_sim, CmfSimResult};
use cortex::{DataSource, Trainer};
use indicatif::{ProgressBar, ProgressStyle};
use retina::Retina;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Anything that stops a run, with the file or stage it concerns.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The retina could not be built.
    #[error("retina: {0}")]
    Retina(#[from] retina::RetinaError),
    /// Training failed (a non-finite loss names the step and the last good checkpoint).
    #[error("cortex: {0}")]
    Cortex(#[from] cortex::CortexError),
    /// CMF-SIM failed.
    #[error("CMF-SIM: {0}")]
    Colorimetry(#[from] colorimetry::ColorimetryError),
    /// Writing the run folder failed.
    #[error("{0}")]
    Io(#[from] crate::io::IoError),
    /// A setting is wrong.
    #[error("{0}")]
    Config(#[from] crate::config::ConfigError),
}

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

/// One CMF-SIM measurement during training.
#[derive(Clone, Debug, Serialize)]
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
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The colour dimensionality CMF-SIM measured at the end (0 when not measured or undefined).
    pub dimension: usize,
    /// Gradient updates done.
    pub steps: u64,
    /// Wall time of the whole run, s.
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

/// Trains a fresh cortex, measures and writes the run folder `out`.
pub fn run(config: &RunConfig, out: &Path, mode: RunMode) -> Result<Summary, RunError> {
    let mut cortex_config = config.cortex.clone();
    cortex_config.train.steps = config.steps;
    run_with_trainer(config, out, mode, Trainer::new(cortex_config)?)
}

/// Continues training the cortex of `checkpoint` on the (changed) eye of `config` for
/// `config.steps` more steps (gene therapy, dimensionality boosting; official §3.9: Adam is
/// recreated, the step count continues).
pub fn run_continued(
    config: &RunConfig,
    out: &Path,
    checkpoint: &Path,
) -> Result<Summary, RunError> {
    println!(
        "  continuing the cortex of {} on cones `{}`",
        checkpoint.display(),
        config.cones
    );
    let trainer = Trainer::continue_from(checkpoint, Some(config.cortex.clone()))?;
    run_with_trainer(
        config,
        out,
        RunMode {
            cmf_sim: true,
            pictures: true,
            progress: true,
        },
        trainer,
    )
}

/// The training loop of [`run`] on a given trainer.
pub fn run_with_trainer(
    config: &RunConfig,
    out: &Path,
    mode: RunMode,
    mut trainer: Trainer,
) -> Result<Summary, RunError> {
    let started = Instant::now();
    if config.learning_rule == "feedback-alignment" {
        trainer.set_learning_rule(Box::new(autodiff::learn::FeedbackAlignment::new(
            config.seed ^ 0xFA,
        )));
        println!("  learning rule: feedback alignment (fixed random backward weights for conv/matmul kernels)");
    }
    std::fs::create_dir_all(out).map_err(|source| crate::io::IoError::Fs {
        path: out.to_path_buf(),
        source,
    })?;
    crate::io::write_atomic(&out.join("config.toml"), config.to_toml().as_bytes())?;
    println!(
        "colorvision: preset `{}`, cones `{}`, seed {}, {} steps → {}",
        config.preset,
        config.cones,
        config.seed,
        config.steps,
        out.display()
    );
    if config.oracle_motion {
        println!("  note: the cortex receives the ORACLE eye motion (true shift) besides the optic nerve signal");
    } else {
        println!(
            "  the cortex receives the optic nerve signal only (eye motion estimated by bucket M)"
        );
    }
    let retina = Retina::new(config.retina.clone())?;
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
    let mut source = RetinaSource::new(retina, config.seed, config.oracle_motion);
    // Held-out batches carry the true motion for evaluation (the estimator's error); the
    // cortex reads it only when the run itself uses the oracle.
    let mut heldout = RetinaSource::new(heldout_retina(config)?, config.seed ^ 0xA5A5, true);
    let estimates_motion = config.cortex.m.mode != cortex::config::MMode::Oracle;
    let bar = if mode.progress {
        ProgressBar::new(config.steps)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    let mut metrics = String::from("step,loss,main_loss,step_ms,heldout_model_mse,heldout_identity_mse,improvement,motion_error_px,dimension\n");
    let mut last_motion_error = None;
    let mut dims: Vec<DimensionPoint> = Vec::new();
    let mut losses: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut step_ms_total = 0.0;
    let schedule = &config.schedule;
    let bs = config.cortex.train.batch_size;
    let checkpoints = out.join("checkpoints");
    let mut last_eval = None;
    let mut last_cmf: Option<CmfSimResult> = None;
    for k in 1..=config.steps {
        let batch = source.next_batch(bs);
        let stats = match trainer.step(&batch) {
            Ok(s) => s,
            Err(e) => {
                bar.abandon_with_message("stopped");
                return Err(e.into());
            }
        };
        step_ms_total += stats.total_ms;
        losses.0.push(k as f64);
        losses.1.push(stats.loss);
        let due = |every: u64| k == config.steps || (every > 0 && k % every == 0);
        let mut row = format!(
            "{k},{},{},{:.3}",
            stats.loss, stats.main_loss, stats.total_ms
        );
        if due(schedule.eval_every_steps) {
            let e = heldout_error(&mut trainer, &mut heldout, bs, schedule.eval_batches)?;
            last_eval = Some(e);
            let _ = write!(row, ",{},{},{}", e[0], e[1], e[2]);
            if estimates_motion {
                let m =
                    heldout_motion_error(&mut trainer, &mut heldout, bs, schedule.eval_batches)?;
                last_motion_error = Some(m);
                let _ = write!(row, ",{m}");
            } else {
                row.push(',');
            }
        } else {
            row.push_str(",,,,");
        }
        if mode.cmf_sim && (due(schedule.cmf_every_steps) || schedule.cmf_extra_steps.contains(&k))
        {
            bar.set_message(format!("loss {:.4} · CMF-SIM…", stats.loss));
            let settings = config.cmf_settings(k == config.steps);
            let r = measure(&settings, config, &source.retina, &trainer)?;
            r.save(out.join("cmf_sim").join(format!("step_{k:06}")))?;
            bar.suspend(|| {
                println!(
                    "  step {k}: CMF-SIM dimension {} ({:.0} s; {} λ, {} sets/K; {})",
                    r.dimension,
                    r.seconds,
                    settings.n_test_wavelengths,
                    settings.sets_per_k,
                    r.verdict
                )
            });
            dims.push(DimensionPoint {
                step: k,
                dimension: r.dimension,
                seconds: r.seconds,
                wall_seconds: started.elapsed().as_secs_f64(),
                sets_per_k: settings.sets_per_k,
                test_wavelengths: settings.n_test_wavelengths,
            });
            let _ = write!(row, ",{}", r.dimension);
            last_cmf = Some(r);
            trainer.save_checkpoint(&checkpoints, Some(&source))?;
        } else {
            row.push(',');
        }
        metrics.push_str(&row);
        metrics.push('\n');
        if mode.pictures
            && schedule.pictures_every_steps > 0
            && k % schedule.pictures_every_steps == 0
            && k != config.steps
        {
            pictures::write_all(
                &out.join("pictures").join(format!("step_{k:06}")),
                config,
                &source.retina,
                &mut heldout,
                &trainer,
            )?;
        }
        if bar.is_hidden() && (k % (config.steps / 10).max(1) == 0) {
            // Not a terminal: a line every tenth of the run instead of a bar.
            println!(
                "  step {k}/{}: loss {:.4}, {:.0} ms/step",
                config.steps, stats.loss, stats.total_ms
            );
        }
        bar.set_position(k);
        bar.set_message(format!(
            "loss {:.4} · {:.0} ms/step",
            stats.loss, stats.total_ms
        ));
        if schedule.stop_at_dimension > 0
            && dims
                .last()
                .is_some_and(|d| d.dimension >= schedule.stop_at_dimension)
        {
            bar.suspend(|| {
                println!(
                    "  reached dimension {} at step {k}: stopping early",
                    schedule.stop_at_dimension
                )
            });
            break;
        }
        if k % 200 == 0 {
            crate::io::write_atomic(&out.join("metrics.csv"), metrics.as_bytes())?;
        }
    }
    bar.finish_and_clear();
    let steps_done = trainer.step_count();
    if trainer.last_checkpoint().is_none_or(|p| {
        !p.to_string_lossy()
            .contains(&cortex::checkpoint::checkpoint_name(steps_done))
    }) {
        trainer.save_checkpoint(&checkpoints, Some(&source))?;
    }
    crate::io::write_atomic(&out.join("metrics.csv"), metrics.as_bytes())?;
    let mut loss_plot = LinePlot::new(
        "Training loss (official §3.8 normalisation)",
        "step",
        "loss",
    );
    loss_plot.log_y = true;
    loss_plot.push(Series::new("loss", losses.0, losses.1));
    loss_plot.save(out.join("loss.svg"))?;
    if !dims.is_empty() {
        let mut p = LinePlot::new(
            "Colour dimensionality over training (CMF-SIM)",
            "step",
            "dimension (0 = undefined: no primary set passed)",
        );
        p.push(Series::new(
            "dimension",
            dims.iter().map(|d| d.step as f64).collect(),
            dims.iter().map(|d| d.dimension as f64).collect(),
        ));
        p.save(out.join("dimension.svg"))?;
    }
    let invariants = if mode.pictures {
        Some(pictures::write_all(
            &out.join("pictures"),
            config,
            &source.retina,
            &mut heldout,
            &trainer,
        )?)
    } else {
        None
    };
    if let Some(r) = &last_cmf {
        r.save(out)?;
    }
    let mut first = Vec::new();
    for d in &dims {
        if d.dimension > 0 && !first.iter().any(|&(k, _, _)| k == d.dimension) {
            first.push((d.dimension, d.step, d.wall_seconds));
        }
    }
    let summary = Summary {
        dimension: last_cmf.as_ref().map_or(0, |r| r.dimension),
        steps: steps_done,
        wall_seconds: started.elapsed().as_secs_f64(),
        mean_step_ms: step_ms_total / steps_done.max(1) as f64,
        oracle_motion: config.oracle_motion,
        dimension_over_steps: dims,
        first_step_at_dimension: first,
        heldout_prediction: last_eval,
        heldout_motion_error_px: last_motion_error,
        verdict: last_cmf
            .as_ref()
            .map_or_else(|| "not measured".to_string(), |r| r.verdict.clone()),
        cmf_sim_per_k: last_cmf.as_ref().map_or_else(Vec::new, |r| {
            let nw = r.test_wavelengths_nm.len();
            r.per_k.iter().map(|k| k.describe(nw)).collect()
        }),
        converged_ratio_per_k: last_cmf.as_ref().map_or_else(Vec::new, |r| {
            r.per_k
                .iter()
                .map(|k| (k.n_primaries, k.converged_worst_ratio))
                .collect()
        }),
        invariants,
        config: config.clone(),
    };
    crate::io::write_json(&out.join("summary.json"), &summary)?;
    Ok(summary)
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
        println!(
            "  learned invariants: C vs true types ARI {}, W vs DoG r {} (surround r {}), P spacing r {:.2}; Neural-Scope hue axis {} (scenes: {})",
            inv.c_adjusted_rand_index.map_or("-".into(), |v| format!("{v:.2}")),
            inv.w_kernel_correlation.map_or("-".into(), |v| format!("{v:.3}")),
            inv.w_surround_correlation.map_or("-".into(), |v| format!("{v:.2}")),
            inv.p_spacing_correlation,
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
