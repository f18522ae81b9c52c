//! What each subcommand does. `main.rs` only parses and dispatches here.

use crate::cli::{CmfSimOptions, CommonOptions, ExperimentOptions, RunDirOptions};
use crate::config::RunConfig;
use crate::experiments;
use crate::observer::LearnedObserver;
use crate::run::{self, RunError, RunMode};
use colorimetry::analytic::ConeObserver;
use colorimetry::{run_cmf_sim, CmfSimResult};
use cortex::Trainer;
use retina::Retina;
use std::path::{Path, PathBuf};

/// `colorvision run`: train, measure at checkpoints, summarise.
pub fn run(options: &CommonOptions) -> Result<(), RunError> {
    let config = RunConfig::resolve(options, "quick")?;
    let out = run::out_dir(&config, options.out.as_ref(), "run");
    let summary = run::run(
        &config,
        &out,
        RunMode {
            cmf_sim: true,
            pictures: true,
            progress: true,
        },
    )?;
    run::print_outcome(&out, &summary);
    Ok(())
}

/// `colorvision train`: train only (no CMF-SIM).
pub fn train(options: &CommonOptions) -> Result<(), RunError> {
    let config = RunConfig::resolve(options, "quick")?;
    let out = run::out_dir(&config, options.out.as_ref(), "train");
    let summary = run::run(
        &config,
        &out,
        RunMode {
            cmf_sim: false,
            pictures: true,
            progress: true,
        },
    )?;
    run::print_outcome(&out, &summary);
    Ok(())
}

/// `colorvision simulate`: pictures of every stage of the eye.
pub fn simulate(options: &CommonOptions) -> Result<(), RunError> {
    let config = RunConfig::resolve(options, "quick")?;
    let out = run::out_dir(&config, options.out.as_ref(), "simulate");
    let retina = Retina::new(config.retina.clone())?;
    let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(config.seed);
    let written = retina::write_stage_pictures(&retina, &mut rng, &out)?;
    println!(
        "colorvision simulate: {} files in {}",
        written.len(),
        out.display()
    );
    for p in written {
        println!("  {}", p.display());
    }
    Ok(())
}

/// Loads the config and last checkpoint of a run folder.
pub fn load_run(dir: &Path) -> Result<(RunConfig, Trainer, PathBuf), RunError> {
    let config_path = dir.join("config.toml");
    let options = CommonOptions {
        preset: None,
        cones: None,
        seed: None,
        steps: None,
        out: None,
        config: Some(config_path),
    };
    let config = RunConfig::resolve(&options, "quick")?;
    let checkpoint =
        cortex::checkpoint::latest_checkpoint(&dir.join("checkpoints"))?.ok_or_else(|| {
            RunError::Config(crate::config::ConfigError::Invalid {
                field: "run".into(),
                reason: format!("{} has no checkpoints/ with a checkpoint", dir.display()),
            })
        })?;
    let trainer = Trainer::continue_from(&checkpoint, Some(config.cortex.clone()))?;
    Ok((config, trainer, checkpoint))
}

/// `colorvision cmf-sim`: on a run folder or an analytic observer.
pub fn cmf_sim(options: &CmfSimOptions) -> Result<(), RunError> {
    let result: (CmfSimResult, PathBuf) = match (&options.run, options.analytic) {
        (Some(dir), _) => {
            let (mut config, trainer, checkpoint) = load_run(dir)?;
            if let Some(k) = options.sets_per_k {
                config.cmf_sim.sets_per_k = k;
            }
            println!(
                "colorvision cmf-sim: {} (checkpoint {})",
                dir.display(),
                checkpoint.display()
            );
            let retina = Retina::new(config.retina.clone())?;
            let observer = LearnedObserver::new(&retina, &trainer.cortex, config.observer.clone());
            (run_cmf_sim(&observer, &config.cmf_sim)?, dir.clone())
        }
        (None, true) => {
            let config = RunConfig::resolve(&options.common, "quick")?;
            let mosaic = retina::mosaic::Mosaic::from_spec_str(&config.cones, 8, 0)?;
            let grid = config.retina.grid.grid()?;
            let observer = ConeObserver::new(&mosaic.classes, &config.retina.template, &grid)?;
            let mut settings = config.cmf_sim.clone();
            if let Some(k) = options.sets_per_k {
                settings.sets_per_k = k;
            }
            let out = run::out_dir(&config, options.common.out.as_ref(), "cmf-sim-analytic");
            (run_cmf_sim(&observer, &settings)?, out)
        }
        (None, false) => {
            return Err(RunError::Config(crate::config::ConfigError::Invalid {
                field: "cmf-sim".into(),
                reason: "give --run DIR (a trained run) or --analytic (with --cones)".into(),
            }))
        }
    };
    let (r, out) = result;
    r.save(&out)?;
    println!(
        "dimension = {}  ({}; {} shows in {:.1} s)",
        r.dimension, r.verdict, r.shows, r.seconds
    );
    for k in &r.per_k {
        println!(
            "  K = {}: {} of {} sets tried, {}",
            k.n_primaries,
            k.sets_tried,
            r.settings.sets_per_k,
            if k.passed {
                "a set passed"
            } else {
                "all failed"
            }
        );
    }
    println!(
        "wrote {}/cmf_sim.json and cmf_sim_errors.svg",
        out.display()
    );
    Ok(())
}

/// `colorvision scope`: Neural Scope pictures and invariants of a trained run.
pub fn scope(options: &RunDirOptions) -> Result<(), RunError> {
    let (config, trainer, _) = load_run(&options.run)?;
    let retina = Retina::new(config.retina.clone())?;
    let mut heldout = crate::source::RetinaSource::new(
        run::heldout_retina(&config)?,
        config.seed ^ 0xA5A5,
        false,
    );
    let dir = options.run.join("pictures");
    let inv = crate::pictures::write_all(&dir, &config, &retina, &mut heldout, &trainer)?;
    println!("Neural Scope pictures in {}", dir.display());
    println!(
        "{}",
        serde_json::to_string_pretty(&inv).expect("plain data")
    );
    Ok(())
}

/// `colorvision experiment NAME`.
pub fn experiment(options: &ExperimentOptions) -> Result<(), RunError> {
    experiments::run_named(&options.name, &options.common)
}
