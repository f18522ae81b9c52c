//! Weight averaging of a run's late checkpoints (`colorvision average --run DIR --steps
//! a,b,c,…`): the cortex whose every parameter is the mean of that parameter over the named
//! checkpoints, measured like a checkpoint — the calibrated CMF-SIM with the run's full budget
//! and the learned invariants.
//!
//! Why: with a constant learning rate the weights keep moving with the minibatch noise, and a
//! measurement of one checkpoint sees one draw of that noise. Averaging the checkpoints of a
//! plateau (stochastic weight averaging, Izmailov et al. 2018) estimates the centre the weights
//! move around. It is a way to read out a trained model, applied identically to every run; it
//! reads only the run's own checkpoints, never the eye.
//!
//! Output, in `--out` or `DIR/average/`: `checkpoints/step_<last>/` (the averaged parameters
//! with the last checkpoint's step and a fresh optimiser's state: `Trainer::continue_from`
//! loads the parameters alone), `cmf_sim.json` and its plot, `average.json`
//! ([`Averaged`]: the steps averaged, the dimension, the margins and the invariants). `gather`
//! shows it beside the run's final figure when it is in `DIR/average/`.
//!
//! Before it loads a checkpoint it checks its memory estimate
//! ([`science::budget::estimate_average`]: a checkpoint's measurement with CMF-SIM and the other
//! checkpoints beside it) against the limit, and writes nothing when it is over.

use crate::cli::AverageOptions;
use crate::run::error::RunError;
use crate::run::measurement_dir::measurement_dir;
use cortex::Trainer;
use science::observer::ObserverKind;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The file `average` writes in its output folder.
pub const AVERAGE_FILE: &str = "average.json";

/// `average`'s output folder inside the run folder when `--out` is not given.
pub const AVERAGE_DIR: &str = "average";

/// Where `average` leaves [`AVERAGE_FILE`] in run folder `run` without `--out` (and where a
/// run's record keeps it).
pub fn averaged_path(run: &Path) -> PathBuf {
    run.join(AVERAGE_DIR).join(AVERAGE_FILE)
}

/// What `average` measured ([`AVERAGE_FILE`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Averaged {
    /// The checkpoints averaged, by step, ascending.
    pub steps: Vec<u64>,
    /// Held-out prediction gain over "next = current" of the averaged cortex.
    pub heldout_gain_averaged: f64,
    /// The same of the last checkpoint alone, on the same held-out batches.
    pub heldout_gain_last_checkpoint: f64,
    /// CMF-SIM's dimension of the averaged cortex (0: undefined, see `verdict`).
    pub dimension: usize,
    /// CMF-SIM's verdict in words.
    pub verdict: String,
    /// Per K tried: `(K, converged max error / threshold over every wavelength)`; < 1 passes.
    pub margins: Vec<(usize, f64)>,
    /// The averaged cortex's learned invariants against the truth (evaluation only).
    pub invariants: science::invariants::Recovery,
}

impl Averaged {
    /// Reads an [`AVERAGE_FILE`]; the error says why it does not read.
    pub fn read(path: &Path) -> Result<Averaged, String> {
        crate::io::read_json(path)
    }

    /// Which checkpoints, e.g. "weights averaged over 8 checkpoints, 34 000–48 000 steps".
    pub fn span(&self) -> String {
        let group = |n: u64| science::summary::digits_grouped(n, ' ');
        let first = self.steps.first().copied().unwrap_or(0);
        let last = self.steps.last().copied().unwrap_or(0);
        format!(
            "weights averaged over {} checkpoints, {}–{} steps",
            self.steps.len(),
            group(first),
            group(last)
        )
    }

    /// What CMF-SIM measured of them, e.g. "3 (K1 20.06, K2 1.36, K3 0.91)".
    pub fn figure(&self) -> String {
        match self.dimension {
            0 => format!("undefined ({})", self.verdict),
            d => format!("{d} ({})", science::summary::margins_text(&self.margins)),
        }
    }
}

/// Sets every parameter of `into` to the mean of that parameter over `into` and `others`.
/// Panics when a parameter's name or shape differs (checkpoints of one run never do).
pub fn average_into(into: &mut Trainer, others: &[Trainer]) {
    let n = (others.len() + 1) as f64;
    let ids: Vec<_> = into.cortex.params.ids().collect();
    for id in ids {
        let name = into.cortex.params.name(id).to_string();
        let mut sum: Vec<f64> = into
            .cortex
            .params
            .get(id)
            .data()
            .iter()
            .map(|&x| x as f64)
            .collect();
        for other in others {
            let o = other.cortex.params.get(id);
            assert_eq!(
                other.cortex.params.name(id),
                name,
                "average: parameter order differs"
            );
            assert_eq!(
                o.data().len(),
                sum.len(),
                "average: {name} has another shape"
            );
            for (s, &x) in sum.iter_mut().zip(o.data()) {
                *s += x as f64;
            }
        }
        for (dst, s) in into
            .cortex
            .params
            .get_mut(id)
            .data_mut()
            .iter_mut()
            .zip(&sum)
        {
            *dst = (s / n) as f32;
        }
    }
}

/// Held-out batches predicted by the averaged and the single cortex alike.
const HELDOUT_BATCHES: usize = 16;

/// "next = current" error over the cortex's on [`HELDOUT_BATCHES`] held-out batches, the same
/// batches on every call (a fresh source with the run's held-out seed).
fn heldout_gain(
    config: &science::config::RunConfig,
    trainer: &mut Trainer,
) -> Result<f64, RunError> {
    let mut heldout = science::heldout::heldout_source(config, true)?;
    let bs = config.cortex.train.batch_size;
    let [_, _, gain] = science::heldout::heldout_error(
        trainer,
        &mut heldout,
        bs,
        HELDOUT_BATCHES,
        crate::interrupt::stop_flag(),
    )?;
    Ok(gain)
}

/// The checkpoint folder of `step` in run folder `dir`.
fn checkpoint_path(dir: &Path, step: u64) -> Result<PathBuf, RunError> {
    let path = dir
        .join("checkpoints")
        .join(cortex::checkpoint::checkpoint_name(step));
    match path.is_dir() {
        true => Ok(path),
        false => Err(RunError::invalid(
            "--steps",
            format!("{} holds no checkpoint of step {step}", dir.display()),
        )),
    }
}

/// The size of checkpoint `dir`'s parameter file, bytes: what loading it holds
/// ([`Trainer::continue_from`] loads the parameters and starts a fresh optimiser); 0 for a file
/// that does not read (loading it then says why).
fn parameters_bytes(dir: &Path) -> f64 {
    std::fs::metadata(dir.join(cortex::checkpoint::CHECKPOINT_FILES[0]))
        .map_or(0.0, |m| m.len() as f64)
}

/// `colorvision average`.
pub fn command(options: &AverageOptions) -> Result<(), RunError> {
    let mut steps = options.steps.clone();
    steps.sort_unstable();
    steps.dedup();
    if steps.len() < 2 {
        return Err(RunError::invalid(
            "--steps",
            "name at least two different checkpoints to average",
        ));
    }
    let dir = &options.run;
    let out = measurement_dir(dir, options.out.as_ref(), AVERAGE_DIR)?;
    let lock = crate::run::lock::RunLock::acquire(dir)?;
    let config = crate::run::folder::read_valid_config(dir)?;
    let paths = steps
        .iter()
        .map(|&s| checkpoint_path(dir, s))
        .collect::<Result<Vec<_>, _>>()?;
    let (last_path, other_paths) = paths.split_last().expect("two or more");
    let others_bytes = other_paths.iter().map(|p| parameters_bytes(p)).sum();
    crate::run::check_estimate(&science::budget::estimate_average(
        &config,
        rayon::current_num_threads(),
        others_bytes,
    ))?;
    let load = |p: &PathBuf| Trainer::continue_from(p, Some(config.cortex.clone()));
    let mut last = load(last_path)?;
    let others = other_paths
        .iter()
        .map(load)
        .collect::<Result<Vec<_>, _>>()?;
    drop(lock);
    // The last checkpoint alone, then the average, predict the same held-out batches: is the
    // average as good a predictor?
    let alone = heldout_gain(&config, &mut last)?;
    average_into(&mut last, &others);
    drop(others);
    let averaged = heldout_gain(&config, &mut last)?;
    println!(
        "  held-out prediction gain over \"next = current\": {averaged:.2} averaged, {alone:.2} at step {}",
        steps.last().expect("two or more")
    );
    let checkpoint = last.save_checkpoint_with(&out.join("checkpoints"), None, None)?;
    println!(
        "averaged {} checkpoints (steps {steps:?}) into {}",
        paths.len(),
        checkpoint.display()
    );
    let mut scenes = science::heldout::hidden_source(&config)?;
    let recovery = science::invariants::measure_with_scenes(
        &last.cortex,
        &mut scenes,
        config.schedule.held_out_scenes,
    );
    for line in recovery.describe() {
        println!("  {line}");
    }
    let r = science::measure::measure_observer(&config, ObserverKind::Cortex, Some(&last))?;
    crate::io::save_into(&out, |d| Ok::<_, RunError>(r.save(d).map(|_| ())?))?;
    let margins: Vec<(usize, f64)> = r
        .per_k
        .iter()
        .map(|k| (k.n_primaries, k.converged_worst_ratio))
        .collect();
    println!(
        "  CMF-SIM: dimension {} ({}); margins {margins:?}",
        r.dimension, r.verdict
    );
    let averaged = Averaged {
        steps: steps.clone(),
        heldout_gain_averaged: averaged,
        heldout_gain_last_checkpoint: alone,
        dimension: r.dimension,
        verdict: r.verdict.clone(),
        margins,
        invariants: recovery,
    };
    crate::io::write_json(&out.join(AVERAGE_FILE), &averaged)?;
    println!("wrote {}/", out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_becomes_the_mean_of_the_checkpoints() {
        let config = science::config::RunConfig::preset("tiny", "LMS")
            .unwrap()
            .cortex;
        let trainer = |offset: f32| {
            let mut t = Trainer::new(config.clone()).unwrap();
            let ids: Vec<_> = t.cortex.params.ids().collect();
            for id in ids {
                for (i, x) in t
                    .cortex
                    .params
                    .get_mut(id)
                    .data_mut()
                    .iter_mut()
                    .enumerate()
                {
                    *x = i as f32 + offset;
                }
            }
            t
        };
        let mut into = trainer(0.0);
        average_into(&mut into, &[trainer(3.0), trainer(6.0)]);
        for id in into.cortex.params.ids() {
            let data = into.cortex.params.get(id).data();
            assert!(data.iter().enumerate().all(|(i, &x)| x == i as f32 + 3.0));
        }
    }
}
