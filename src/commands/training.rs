//! `run`, `train` and `resume`: the subcommands that train a cortex in a run folder.

use crate::cli::{CommonOptions, ResumeOptions, RunOptions};
use crate::run::error::RunError;
use crate::run::folder::Folder;
use crate::run::{self, RunMode};
use science::config::RunConfig;
use std::path::{Path, PathBuf};

/// `colorvision run`: train, measure at checkpoints, summarise.
pub fn run(options: &RunOptions) -> Result<(), RunError> {
    train_and_report(options, "run", RunMode::FULL)
}

/// `colorvision train`: train only (no CMF-SIM).
pub fn train(options: &RunOptions) -> Result<(), RunError> {
    let mode = RunMode {
        cmf_sim: false,
        ..RunMode::FULL
    };
    train_and_report(options, "train", mode)
}

fn train_and_report(options: &RunOptions, command: &str, mode: RunMode) -> Result<(), RunError> {
    let (config, out) = resolve_run(&options.common, command)?;
    let start = options
        .continue_from
        .as_deref()
        .map(|path| crate::run::folder::checkpoint_to_continue(path, &config))
        .transpose()?;
    install_signals()?;
    let origin = match &start {
        Some(checkpoint) => run::Origin::Continue(checkpoint),
        None => run::Origin::New,
    };
    let summary = run::run_in(&config, &out, mode, options.common.folder(), origin)?;
    run::print_outcome(&out, &summary);
    Ok(())
}

/// Catches SIGINT/SIGTERM so a run stops after a step with a checkpoint.
pub(super) fn install_signals() -> Result<(), RunError> {
    crate::interrupt::install()
        .map_err(|e| RunError::invalid("signals", format!("cannot catch SIGINT/SIGTERM: {e}")))
}

/// The config and run folder of `run`/`train` (the `main` preset unless told otherwise). With
/// `--resume` and no option that changes the settings, the folder's own `config.toml` is the
/// config (any option given must agree with it, which [`run::run_in`] checks).
pub fn resolve_run(
    options: &CommonOptions,
    command: &str,
) -> Result<(RunConfig, PathBuf), RunError> {
    if let Some(out) = options.out.as_ref().filter(|_| options.resume) {
        let never_started =
            crate::run::temporaries::resume_never_started(out, options.sets_anything())?;
        if !never_started && !out.join("config.toml").is_file() {
            return Err(RunError::Folder {
                path: out.clone(),
                reason: "holds no run to resume (no config.toml)".into(),
            });
        }
        if !options.sets_anything() {
            let config = crate::run::folder::read_config(out)?;
            config.validate()?;
            return Ok((config, out.clone()));
        }
    }
    let config = options.resolve("main")?;
    let out = run::out_dir(&config, options.out.as_ref(), command);
    Ok((config, out))
}

/// `colorvision resume DIR`: continues the run of `DIR` (made by `run`, `train` or an
/// experiment) as its `run.json` and `config.toml` say.
pub fn resume(options: &ResumeOptions) -> Result<(), RunError> {
    let dir = &options.dir;
    let marker_path = dir.join(crate::run::folder::MARKER_FILE);
    if let Some(pid) = crate::run::lock::live_holder(dir) {
        return Err(RunError::Folder {
            path: dir.clone(),
            reason: format!(
                "is in use by process {pid}, which is training into it: wait for it to \
                 finish or stop it"
            ),
        });
    }
    if crate::run::temporaries::holds_only_temporaries(dir)? {
        return Err(crate::run::temporaries::never_started(dir));
    }
    if !dir.join("config.toml").is_file() {
        return Err(RunError::Folder {
            path: dir.clone(),
            reason: "is not a run folder (no config.toml); an experiment's folder continues \
                     with `experiment NAME --out DIR --resume`"
                .into(),
        });
    }
    if !marker_path.is_file() {
        return Err(RunError::Folder {
            path: dir.clone(),
            reason: "holds config.toml but no run.json, so how it was run is not known (a \
                     start stopped between the two by an older version): continue it with \
                     `colorvision run --out DIR --resume` (or `train`), which writes run.json"
                .into(),
        });
    }
    let text = std::fs::read_to_string(&marker_path).map_err(crate::io::fs_err(&marker_path))?;
    let marker: run::RunMarker = serde_json::from_str(&text).map_err(|e| RunError::Folder {
        path: marker_path.clone(),
        reason: format!("invalid run marker: {e}"),
    })?;
    let mut config = crate::run::folder::read_config(dir)?;
    config.validate()?;
    if let Some(steps) = options.steps {
        extend_run(dir, &mut config, steps)?;
    }
    install_signals()?;
    let mode = RunMode {
        cmf_sim: marker.cmf_sim,
        pictures: marker.pictures,
        progress: true,
    };
    let origin_checkpoint = marker.origin_checkpoint(dir);
    let origin = match &origin_checkpoint {
        Some(p) => run::Origin::Continue(p),
        None => run::Origin::New,
    };
    let summary = run::run_in(&config, dir, mode, Folder::Resume, origin)?;
    run::print_outcome(dir, &summary);
    Ok(())
}

/// `resume --steps N`: raise the run's step count to `steps` (never lower it). A finished
/// run's summary.json is first renamed to summary_step_<old>.json, then config.toml is
/// rewritten (each step atomic: a stop between them leaves the old run, unfinished).
fn extend_run(dir: &Path, config: &mut RunConfig, steps: u64) -> Result<(), RunError> {
    let old = config.steps;
    if steps < old {
        return Err(RunError::invalid("--steps", format!(
                "{steps} is below the run's {old} steps in {}: a run can be extended, not shortened",
                dir.join("config.toml").display()
            )));
    }
    if steps == old {
        return Ok(());
    }
    // Continuing needs the per-step log up to the checkpoint (`run::open` restores it); a
    // record in results/ keeps none. Said before anything in the folder changes.
    let metrics = dir.join("metrics.csv");
    if !metrics.is_file() {
        return Err(RunError::Folder {
            path: metrics,
            reason: "is missing: a run is extended from its per-step log and its newest \
                     checkpoint (a record in results/ keeps no per-step log; extend the run \
                     folder it was trained in)"
                .into(),
        });
    }
    config.steps = steps;
    config.cortex.train.steps = steps;
    config.validate()?;
    let summary = dir.join("summary.json");
    if summary.is_file() {
        let kept = dir.join(format!("summary_step_{old}.json"));
        std::fs::rename(&summary, &kept).map_err(crate::io::fs_err(&summary))?;
        println!("  the finished run's summary is kept as {}", kept.display());
    }
    crate::io::write_atomic(&dir.join("config.toml"), config.to_toml().as_bytes())?;
    println!("  extending the run from {old} to {steps} steps");
    Ok(())
}
