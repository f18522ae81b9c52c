//! What each subcommand does. `main.rs` only parses and dispatches here.

use crate::cli::{
    CmfSimOptions, CommonOptions, ConvergenceOptions, ExperimentOptions, ReadoutArg, RunDirOptions,
};
use crate::experiments;
use crate::run::error::RunError;
use crate::run::measurement_dir::measurement_dir;
use crate::run::{self};
use colorimetry::CmfSimResult;
use retina::Retina;
use science::observer::{ObserverKind, ReadoutMode};

mod training;
use training::install_signals;
pub use training::{resolve_run, resume, run, train};

/// `colorvision simulate`: pictures of every stage of the eye.
pub fn simulate(options: &CommonOptions) -> Result<(), RunError> {
    refuse_training_options(options, "simulate", true)?;
    let config = options.resolve("quick")?;
    let out = run::out_dir(&config, options.out.as_ref(), "simulate");
    crate::run::folder::refuse_file(&out)?;
    run::check_estimate(&science::budget::estimate_eye(&config))?;
    let retina = crate::scene_bar::retina(config.retina.clone())?;
    let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(config.seed);
    let mut written = Vec::new();
    crate::io::save_into(&out, |staging| -> Result<(), RunError> {
        for p in retina::write_stage_pictures(&retina, &mut rng, staging)? {
            written.push(out.join(p.strip_prefix(staging).unwrap_or(&p)));
        }
        Ok(())
    })?;
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

/// `simulate` and `gamut` train nothing: `--resume` and `--force` (and for `simulate`, which
/// draws no batches, `--steps`) are errors naming them, not dropped.
fn refuse_training_options(
    options: &CommonOptions,
    command: &str,
    refuse_steps: bool,
) -> Result<(), RunError> {
    let given = first_given(&[
        ("--steps", refuse_steps && options.steps.is_some()),
        ("--resume", options.resume),
        ("--force", options.force),
    ]);
    match given {
        Some(option) => Err(RunError::invalid(
            option,
            format!(
                "`{command}` trains nothing{} (its files replace those of an earlier \
                 `{command}` in the folder)",
                if option == "--steps" {
                    " and draws no batches"
                } else {
                    ""
                }
            ),
        )),
        None => Ok(()),
    }
}

/// `colorvision gamut`: the CMF-SIM test lights against the colours of the eye's training
/// scenes, sampled over the batches a training with these settings (its `steps`) draws.
pub fn gamut(options: &CommonOptions) -> Result<(), RunError> {
    refuse_training_options(options, "gamut", false)?;
    let config = options.resolve("quick")?;
    let out = run::out_dir(&config, options.out.as_ref(), "gamut");
    crate::run::folder::refuse_file(&out)?;
    run::check_estimate(&science::budget::estimate_eye(&config))?;
    let s = &config.cmf_sim;
    let tests = colorimetry::WavelengthGrid::linspace(
        s.test_range_nm.0,
        s.test_range_nm.1,
        s.n_test_wavelengths,
    )
    .map_err(|e| RunError::invalid("cmf_sim.n_test_wavelengths", e.to_string()))?;
    let retina = Retina::new(config.retina.clone())?;
    let mut source = science::source::RetinaSource::new(retina, config.seed, false);
    let g = science::gamut::measure(&mut source, tests.wavelengths_nm(), config.steps);
    let beyond: Vec<String> = g
        .beyond(10.0)
        .iter()
        .map(|(a, b)| format!("{a:.0}–{b:.0} nm"))
        .collect();
    println!(
        "colorvision gamut: {} test lights against {} colours of the training scenes ({} cones; \
         {} frames spread over the {} batches of a training with these settings)",
        g.wavelengths_nm.len(),
        g.scene_colours,
        g.classes.join(""),
        g.frames,
        g.batches
    );
    println!(
        "  lights more than 10° from every scene colour: {}",
        if beyond.is_empty() {
            "none".to_string()
        } else {
            beyond.join(", ")
        }
    );
    let md = g.markdown((g.wavelengths_nm.len() / 25).max(1));
    print!("{md}");
    crate::io::save_into(&out, |dir| -> Result<(), RunError> {
        crate::io::write_json(&dir.join("gamut.json"), &g)?;
        crate::io::write_atomic(&dir.join("gamut.md"), g.markdown(1).as_bytes())?;
        Ok(())
    })?;
    println!("wrote {}/gamut.json and gamut.md", out.display());
    Ok(())
}

/// `colorvision convergence`: every checkpoint of a run folder measured the same way.
pub fn convergence(options: &ConvergenceOptions) -> Result<(), RunError> {
    let scenes = options.held_out_scenes;
    let batch = science::invariants::HIDDEN_BATCH_SIZE;
    if scenes < 2 * batch || !scenes.is_multiple_of(batch) {
        return Err(RunError::invalid(
            "--held-out-scenes",
            format!(
                "{scenes}: needs a multiple of {batch}, at least {}",
                2 * batch
            ),
        ));
    }
    let cmf = match (options.cmf, options.cmf_steps.is_empty()) {
        (false, _) => crate::convergence::CmfAt::Never,
        (true, true) => crate::convergence::CmfAt::Every,
        (true, false) => crate::convergence::CmfAt::Steps(options.cmf_steps.clone()),
    };
    let side_by_side = match (&options.out, options.run.len()) {
        (Some(out), _) => Some(out),
        (None, 1) => None,
        (None, _) => {
            return Err(RunError::invalid(
                "--out",
                "several runs (--run … --run …) need a folder for their side-by-side plots",
            ))
        }
    };
    let mut runs = Vec::new();
    for dir in &options.run {
        let config = crate::run::folder::read_valid_config(dir)?;
        run::check_estimate(&science::budget::estimate_convergence(
            &config,
            options.cmf,
            rayon::current_num_threads(),
            options.held_out_scenes,
        ))?;
        println!(
            "colorvision convergence: {}{}",
            dir.display(),
            if options.cmf { " (with CMF-SIM)" } else { "" }
        );
        let rows = crate::convergence::study(dir, &cmf, &options.steps, scenes)?;
        println!(
            "{} checkpoints; wrote {}/convergence/convergence.md, .json and convergence_*.svg",
            rows.len(),
            dir.display()
        );
        let seed = crate::run::folder::read_config(dir).map(|c| c.seed);
        let name = dir.file_name().map_or(dir.display().to_string(), |n| {
            n.to_string_lossy().into_owned()
        });
        let label = seed.map_or(name.clone(), |s| format!("{name} (seed {s})"));
        runs.push((label, rows));
    }
    if let Some(out) = side_by_side {
        crate::convergence::runs::write(out, &runs)?;
        println!("wrote {}/runs.md and runs_*.svg", out.display());
    }
    Ok(())
}

/// `colorvision cmf-sim`: on a run folder's cortex or on an observer whose answer is known.
pub fn cmf_sim(options: &CmfSimOptions) -> Result<(), RunError> {
    let kind = options.observer.unwrap_or(if options.run.is_some() {
        ObserverKind::Cortex
    } else {
        ObserverKind::Oracle
    });
    let (mut config, trainer, out) =
        match (&options.run, kind) {
            (Some(dir), ObserverKind::Cortex) => {
                let out = measurement_dir(dir, options.common.out.as_ref(), "cmf-sim")?;
                refuse_eye_options_with_run(&options.common)?;
                let (config, trainer, checkpoint) =
                    crate::run::folder::load_run_step(dir, options.checkpoint_step)?;
                let config = config.with_measurement_settings(&options.common.set)?;
                println!(
                    "colorvision cmf-sim: {} (checkpoint {})",
                    dir.display(),
                    checkpoint.display()
                );
                (config, Some(trainer), out)
            }
            (None, ObserverKind::Cortex) => {
                return Err(RunError::invalid(
                    "--observer",
                    "`cortex` needs --run DIR (a trained run)",
                ))
            }
            (Some(_), _) => return Err(RunError::invalid(
                "--run",
                "only the `cortex` observer reads a run folder; the others take --preset/--cones",
            )),
            (None, _) if options.checkpoint_step.is_some() => {
                return Err(RunError::invalid(
                    "--checkpoint-step",
                    "names a checkpoint of --run DIR, and no --run was given",
                ))
            }
            (None, _) => {
                let config = options.common.resolve("quick")?;
                let name = format!("cmf-sim-{}", kind.name());
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
    if let Some(r) = options.patch_radius_fraction {
        config.observer.patch_radius_fraction = r;
    }
    if let Some(c) = options.edge_clearance_cones {
        config.observer.edge_clearance_cones = Some(c);
    }
    if let Some(r) = options.readout {
        config.observer.readout = match r {
            ReadoutArg::Resolved => ReadoutMode::Resolved,
            ReadoutArg::PatchMean => ReadoutMode::PatchMean,
        };
    }
    config.validate()?;
    let measured = science::measure::measurement_config(&config);
    run::check_estimate(&science::budget::estimate_cmf_sim(
        &measured,
        kind,
        rayon::current_num_threads(),
    ))?;
    install_signals()?;
    crate::interrupt::during("CMF-SIM", "nothing was written");
    let stop = crate::interrupt::stop_flag();
    let r = science::measure::measure_observer_until(&config, kind, trainer.as_ref(), stop)
        .map_err(|e| RunError::from(e).said_as_stop(|| "nothing was written".into()))?;
    r.save(&out)?;
    print_cmf_sim(&r);
    println!(
        "wrote {}/cmf_sim.json and cmf_sim_errors.svg",
        out.display()
    );
    Ok(())
}

/// With `--run` the eye and the cortex are the run's: an option that would change them is an
/// error naming it (only `--set cmf_sim.*`/`observer.*` and `--out` apply).
fn refuse_eye_options_with_run(common: &crate::cli::CommonOptions) -> Result<(), RunError> {
    match eye_option_given(common) {
        Some(option) => Err(RunError::invalid(
            option,
            "a measurement of --run DIR uses the run's own eye and cortex (its config.toml); \
             use --location-seed for other draws, --set cmf_sim.KEY=VALUE or \
             --set observer.KEY=VALUE for the measurement's settings",
        )),
        None => Ok(()),
    }
}

/// `scope` and `stiles-burch` read a run folder with the settings it was trained with: any
/// setting given (`--set` too) is an error naming it, not dropped; `--out` and
/// `--checkpoint-step` apply.
pub(crate) fn refuse_settings_with_run(
    common: &crate::cli::CommonOptions,
    command: &str,
) -> Result<(), RunError> {
    let given = eye_option_given(common).or((!common.set.is_empty()).then_some("--set"));
    match given {
        Some(option) => Err(RunError::invalid(
            option,
            format!(
                "`{command} --run DIR` uses the run's own settings (its config.toml); only \
                 --out and --checkpoint-step apply"
            ),
        )),
        None => Ok(()),
    }
}

/// The first option of `common` that would change a run's eye or cortex, if any is given.
fn eye_option_given(common: &crate::cli::CommonOptions) -> Option<&'static str> {
    first_given(&[
        ("--preset", common.preset.is_some()),
        ("--cones", common.cones.is_some()),
        ("--seed", common.seed.is_some()),
        ("--steps", common.steps.is_some()),
        ("--config", common.config.is_some()),
        ("--scene", common.scene.is_some()),
        ("--resume", common.resume),
        ("--force", common.force),
    ])
}

/// The name of the first `(option, given)` pair that is given.
fn first_given(options: &[(&'static str, bool)]) -> Option<&'static str> {
    options
        .iter()
        .find(|(_, on)| *on)
        .map(|(option, _)| *option)
}

/// The verdict, the base error against the energy, and each K's converged margin, in words.
pub fn print_cmf_sim(r: &CmfSimResult) {
    for line in cmf_sim_lines(r) {
        println!("{line}");
    }
}

/// The lines [`print_cmf_sim`] prints.
pub fn cmf_sim_lines(r: &CmfSimResult) -> Vec<String> {
    let (base, energy): (f64, f64) = (r.base_error.iter().sum(), r.energy.iter().sum());
    let mut lines = vec![
        format!(
            "{}: dimension {} — {} ({} shows in {:.1} s)",
            r.observer, r.dimension, r.verdict, r.shows, r.seconds
        ),
        format!(
            "  base error (the same light at two locations) summed over wavelengths = {:.3} of the percept energy{}",
            base / energy.max(f64::MIN_POSITIVE),
            if r.no_colour_constancy {
                " (≥ 1: no colour constancy)"
            } else {
                ""
            }
        ),
    ];
    let nw = r.test_wavelengths_nm.len();
    lines.extend(r.per_k.iter().map(|k| format!("  {}", k.describe(nw))));
    lines
}

/// `colorvision scope`: Neural Scope pictures and invariants of a trained run (the percept's
/// hue-angle error, the hue axes, what the eye hides; `scope.json`), written to `--out` or
/// `DIR/scope/` (never over the run's own `pictures/`).
pub fn scope(options: &RunDirOptions) -> Result<(), RunError> {
    refuse_settings_with_run(&options.common, "scope")?;
    // What `convergence` of one checkpoint holds without CMF-SIM: the eye, one scene pool and
    // the held-out samples of the run's `schedule.held_out_scenes`.
    let config = crate::run::folder::read_valid_config(&options.run)?;
    run::check_estimate(&science::budget::estimate_convergence(
        &config,
        false,
        rayon::current_num_threads(),
        config.schedule.held_out_scenes,
    ))?;
    let dir = measurement_dir(&options.run, options.common.out.as_ref(), "scope")?;
    let (config, trainer, _) =
        crate::run::folder::load_run_step(&options.run, options.checkpoint_step)?;
    let retina = Retina::new(config.retina.clone())?;
    let mut heldout = science::heldout::heldout_source(&config, false)?;
    let inv = crate::pictures::write_all(&dir, &config, &retina, &mut heldout, &trainer, true)?;
    crate::io::write_json(&dir.join("scope.json"), &inv)?;
    println!("Neural Scope pictures and scope.json in {}", dir.display());
    println!(
        "{}",
        serde_json::to_string_pretty(&inv).expect("plain data")
    );
    Ok(())
}

/// `colorvision experiment NAME`.
pub fn experiment(options: &ExperimentOptions) -> Result<(), RunError> {
    install_signals()?;
    experiments::run_named(&options.name, &options.common)
}

/// `colorvision sweep`: see [`crate::sweep`].
pub fn sweep(options: &crate::sweep::SweepOptions) -> Result<(), RunError> {
    crate::sweep::command(options)
}

/// `colorvision gather`: see [`crate::gather`].
pub fn gather(options: &crate::gather::GatherOptions) -> Result<(), RunError> {
    crate::gather::command(options)
}
