//! What each subcommand does. `main.rs` only parses and dispatches here.

use crate::cli::{
    CmfSimOptions, CommonOptions, ExperimentOptions, ObserverKind, ReadoutArg, RunDirOptions,
};
use crate::config::RunConfig;
use crate::experiments;
use crate::observer::ReadoutMode;
use crate::run::{self, RunError, RunMode};
use colorimetry::CmfSimResult;
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

/// `colorvision cmf-sim`: on a run folder's cortex or on an observer whose answer is known.
pub fn cmf_sim(options: &CmfSimOptions) -> Result<(), RunError> {
    let kind = options.observer.unwrap_or(if options.run.is_some() {
        ObserverKind::Cortex
    } else {
        ObserverKind::Oracle
    });
    let (mut config, trainer, out) = match (&options.run, kind) {
        (Some(dir), ObserverKind::Cortex) => {
            let (config, trainer, checkpoint) = load_run(dir)?;
            println!(
                "colorvision cmf-sim: {} (checkpoint {})",
                dir.display(),
                checkpoint.display()
            );
            let out = options
                .common
                .out
                .clone()
                .unwrap_or_else(|| dir.join("cmf-sim"));
            (config, Some(trainer), out)
        }
        (None, ObserverKind::Cortex) => {
            return Err(invalid_option(
                "--observer",
                "`cortex` needs --run DIR (a trained run)",
            ))
        }
        (Some(_), _) => {
            return Err(invalid_option(
                "--run",
                "only the `cortex` observer reads a run folder; the others take --preset/--cones",
            ))
        }
        (None, _) => {
            let config = RunConfig::resolve(&options.common, "quick")?;
            let value = clap::ValueEnum::to_possible_value(&kind).expect("every kind has a name");
            let name = format!("cmf-sim-{}", value.get_name());
            let out = run::out_dir(&config, options.common.out.as_ref(), &name);
            (config, None, out)
        }
    };
    if let Some(k) = options.sets_per_k {
        config.cmf_sim.sets_per_k = k;
    }
    if let Some(seed) = options.location_seed {
        config.cmf_sim.seed = seed;
    }
    if let Some(r) = options.readout {
        config.observer.readout = match r {
            ReadoutArg::Resolved => ReadoutMode::Resolved,
            ReadoutArg::PatchMean => ReadoutMode::PatchMean,
        };
    }
    config.validate()?;
    let r = crate::ladder::measure_observer(&config, kind, trainer.as_ref())?;
    r.save(&out)?;
    print_cmf_sim(&r);
    println!(
        "wrote {}/cmf_sim.json and cmf_sim_errors.svg",
        out.display()
    );
    Ok(())
}

/// The verdict, the base error against the energy, and each K's converged margin, in words.
pub fn print_cmf_sim(r: &CmfSimResult) {
    let (base, energy): (f64, f64) = (r.base_error.iter().sum(), r.energy.iter().sum());
    println!(
        "{}: dimension {} — {} ({} shows in {:.1} s)",
        r.observer, r.dimension, r.verdict, r.shows, r.seconds
    );
    println!(
        "  base error (the same light at two locations) summed over wavelengths = {:.3} of the percept energy{}",
        base / energy.max(f64::MIN_POSITIVE),
        if r.no_colour_constancy {
            " (≥ 1: no colour constancy)"
        } else {
            ""
        }
    );
    let nw = r.test_wavelengths_nm.len();
    for k in &r.per_k {
        println!("  {}", k.describe(nw));
    }
}

fn invalid_option(option: &str, reason: &str) -> RunError {
    RunError::Config(crate::config::ConfigError::Invalid {
        field: option.into(),
        reason: reason.into(),
    })
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
