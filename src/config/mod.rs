//! The resolved settings of a run: a preset, then a TOML file, then command-line options, each
//! overriding the last. Every number is a config value; a preset is a named set of them.
//!
//! A TOML file may give any subset of the fields; unknown fields are errors that name the file
//! and the field (a typo never silently does nothing). The resolved config is written into the
//! run folder as `config.toml`, so a run can be repeated with `--config runs/X/config.toml`.

use crate::cli::CommonOptions;
use crate::observer::ObserverSettings;
use colorimetry::cmf_sim::CmfSimSettings;
use cortex::CortexConfig;
use retina::RetinaConfig;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod resolve;
mod validate;

pub use resolve::one_line;

/// A configuration problem, naming the file and field where there is one.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not valid TOML or has a wrong/unknown field.
    #[error("{path}: {message}")]
    Parse {
        /// The file (or `<preset>` for a command-line value).
        path: String,
        /// The TOML parser's message, which names the field.
        message: String,
    },
    /// A value is out of range.
    #[error("setting `{field}`: {reason}")]
    Invalid {
        /// The field.
        field: String,
        /// Why.
        reason: String,
    },
    /// A value from a config file is out of range.
    #[error("{path}: setting `{field}`: {reason}")]
    InFile {
        /// The file.
        path: String,
        /// The field.
        field: String,
        /// Why.
        reason: String,
    },
}

/// When a run checkpoints, measures and draws.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Schedule {
    /// Steps between CMF-SIM measurements (0: only at the end).
    pub cmf_every_steps: u64,
    /// Further steps at which CMF-SIM measures (early training, where the dimension grows).
    pub cmf_extra_steps: Vec<u64>,
    /// Steps between pictures (0: only at the end).
    pub pictures_every_steps: u64,
    /// Steps between held-out prediction-error measurements.
    pub eval_every_steps: u64,
    /// Held-out batches per prediction-error measurement.
    pub eval_batches: usize,
    /// Stop training early once CMF-SIM has reported this dimension (0: never stop early).
    pub stop_at_dimension: usize,
    /// Primary sets per K for the CMF-SIM measurements during training (0: as `cmf_sim`). The
    /// measurement after the last step always uses the full `cmf_sim` budget.
    pub checkpoint_cmf_sets_per_k: usize,
    /// Test wavelengths for the measurements during training (0: as `cmf_sim`).
    pub checkpoint_cmf_wavelengths: usize,
    /// Location pairs for the measurements during training (0: as `cmf_sim`).
    pub checkpoint_cmf_location_pairs: usize,
}

/// Everything a run needs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Preset the values started from.
    pub preset: String,
    /// Cone types (see `--cones`).
    pub cones: String,
    /// Seed of every random draw.
    pub seed: u64,
    /// Gradient updates.
    pub steps: u64,
    /// Use the oracle eye motion (said in the run's output when on).
    pub oracle_motion: bool,
    /// Credit assignment: `backprop` (default), `feedback-alignment`,
    /// `direct-feedback-alignment` or `forward-forward` (`cortex::rule`).
    pub learning_rule: cortex::RuleKind,
    /// The eye.
    pub retina: RetinaConfig,
    /// The cortex.
    pub cortex: CortexConfig,
    /// CMF-SIM.
    pub cmf_sim: CmfSimSettings,
    /// The observer CMF-SIM probes.
    pub observer: ObserverSettings,
    /// Checkpoints, measurements, pictures.
    pub schedule: Schedule,
}

/// The named sets of settings, in the order the help lists them.
pub const PRESETS: [&str; 5] = ["tiny", "quick", "long", "sandbox", "paper"];

/// Steps of the `long` preset: the quick eye trained until the convergence study of
/// docs/measurements.md (three seeds) finds its held-out prediction gain flat (10–11 from
/// 16 000 steps on) and the learned invariants settled (C recall ≥ 0.97, P 0.3–0.4 cone
/// spacings). Its CMF-SIM dimension is not settled there: from 24 000 to 40 000 steps the seeds'
/// checkpoints fall on either side of the border between 2 and 3. The default `quick` run stops at 6 000 steps to stay within
/// half an hour on 2 cores.
pub const LONG_STEPS: u64 = 40_000;

impl RunConfig {
    /// The named preset with `cones`.
    pub fn preset(name: &str, cones: &str) -> Result<RunConfig, ConfigError> {
        let invalid = |reason: String| ConfigError::Invalid {
            field: "preset".into(),
            reason,
        };
        if !PRESETS.contains(&name) {
            return Err(invalid(format!(
                "`{name}` is not one of {}",
                PRESETS.join(", ")
            )));
        }
        // `long` is the quick eye and cortex, trained until prediction and invariants plateau.
        let eye = if name == "long" { "quick" } else { name };
        let mut retina = RetinaConfig::preset(eye).map_err(|e| invalid(e.to_string()))?;
        retina.cones = cones.to_string();
        let mut cortex = CortexConfig::preset(eye).map_err(|e| invalid(e.to_string()))?;
        if name == "long" {
            cortex.train.checkpoint_every_steps = 2000;
        }
        if eye == "quick" {
            // The quick run uses the oracle eye motion (announced in its output), which keeps
            // it inside its time budget: the learned estimator (`[cortex.m] mode = "learned"`,
            // `oracle_motion = false` in a config file) trains stably since the gauge term
            // (cortex::buckets::m::gauge) but costs ~50 % more per step.
            cortex.m.mode = cortex::config::MMode::Oracle;
        }
        let (steps, cmf_every, sets_per_k, wavelengths, pairs) = match name {
            // tiny: the calibration ladder (crate::ladder) returns every known answer up to
            // 3-D on this eye with 4 location pairs and 20 sets per K (with 2 pairs and 8
            // sets an LMS cone-activation observer measured 2-D); the 32² eye cannot carry a
            // fourth class (its tetrachromat oracles fail K = 4 at 3–4 of 5 seeds).
            "tiny" => (300, 0, 20, 30, 4),
            "sandbox" => (3000, 1000, 20, 50, 4),
            "paper" => (100_000, 10_000, 100, 100, 8),
            // long: the quick eye trained as long as the convergence study says (see
            // LONG_STEPS), with the small budget every 8 000 steps.
            "long" => (LONG_STEPS, 8000, 100, 100, 8),
            // quick: CMF-SIM at the end with a paper-like budget (100 wavelengths, 8 location
            // pairs as the authors' code, docs/references.md#cmf-sim-defaults; 100 sets per K,
            // the paper used 500): 1.5–4 min on a trained quick cortex. During training a
            // smaller budget (below) draws the dimension over steps (Fig. 3.3).
            _ => (6000, 1500, 100, 100, 8),
        };
        // Early measurements catch the growth of the dimension (paper Fig. 3.3: 1-D, 2-D, 3-D).
        let extra_steps = match name {
            "quick" => vec![50, 100, 250, 500],
            "long" => vec![50, 100, 250, 500, 1000, 2000, 4000],
            _ => Vec::new(),
        };
        // The budget during training: each measurement should stay near a minute. 30 sets per
        // K: with 5, a quick MS dichromat's K = 2 failed by chance (its 10th set passed): too
        // few sets overstate the dimension.
        let (checkpoint_sets, checkpoint_wavelengths, checkpoint_pairs) = match eye {
            "quick" => (30, 50, 4),
            _ => (0, 0, 0),
        };
        let cmf_sim = CmfSimSettings {
            sets_per_k,
            n_test_wavelengths: wavelengths,
            location_pairs: pairs,
            max_primaries: 4,
            ..CmfSimSettings::default()
        };
        // One setting: the run's `steps` is the cortex's.
        cortex.train.steps = steps;
        Ok(RunConfig {
            preset: name.to_string(),
            cones: cones.to_string(),
            seed: 0,
            steps,
            oracle_motion: matches!(cortex.m.mode, cortex::config::MMode::Oracle),
            learning_rule: cortex::RuleKind::Backprop,
            retina,
            cortex,
            cmf_sim,
            observer: ObserverSettings {
                // The 32-cone eye needs a larger patch for enough cones inside it (radius
                // 12.8 px of 64, about 6 cones) — the ladder's S-cone rungs fail at 1/8.
                patch_radius_fraction: if name == "tiny" { 0.2 } else { 0.125 },
                ..ObserverSettings::default()
            },
            schedule: Schedule {
                cmf_every_steps: cmf_every,
                cmf_extra_steps: extra_steps,
                pictures_every_steps: steps.max(1) / 4,
                eval_every_steps: (steps / 20).max(10),
                eval_batches: 4,
                stop_at_dimension: 0,
                checkpoint_cmf_sets_per_k: checkpoint_sets,
                checkpoint_cmf_wavelengths: checkpoint_wavelengths,
                checkpoint_cmf_location_pairs: checkpoint_pairs,
            },
        })
    }

    /// The CMF-SIM settings for a measurement during training (the schedule's smaller budget
    /// where it sets one); `final_step` measurements use `cmf_sim` unchanged.
    pub fn cmf_settings(&self, final_step: bool) -> CmfSimSettings {
        let mut s = self.cmf_sim.clone();
        if !final_step {
            let pick = |v: usize, full: usize| if v == 0 { full } else { v };
            s.sets_per_k = pick(self.schedule.checkpoint_cmf_sets_per_k, s.sets_per_k);
            s.n_test_wavelengths = pick(
                self.schedule.checkpoint_cmf_wavelengths,
                s.n_test_wavelengths,
            );
            s.location_pairs = pick(
                self.schedule.checkpoint_cmf_location_pairs,
                s.location_pairs,
            );
        }
        s
    }

    /// The resolved config as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("a RunConfig serialises to TOML")
    }

    /// The default run folder: `runs/<command>-<preset>-<cones>-seed<seed>`.
    pub fn default_out(&self, command: &str) -> PathBuf {
        let cones: String = self
            .cones
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        Path::new("runs").join(format!(
            "{command}-{}-{cones}-seed{}",
            self.preset, self.seed
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(config: Option<PathBuf>) -> CommonOptions {
        CommonOptions {
            config,
            ..CommonOptions::default()
        }
    }

    #[test]
    fn the_checkpoint_budget_applies_during_training_only() {
        let c = RunConfig::preset("quick", "LMS").unwrap();
        let during = c.cmf_settings(false);
        let last = c.cmf_settings(true);
        assert_eq!(
            last, c.cmf_sim,
            "the final measurement uses the full budget"
        );
        assert_eq!(
            (
                during.sets_per_k,
                during.n_test_wavelengths,
                during.location_pairs
            ),
            (
                c.schedule.checkpoint_cmf_sets_per_k,
                c.schedule.checkpoint_cmf_wavelengths,
                c.schedule.checkpoint_cmf_location_pairs
            )
        );
        assert!(during.sets_per_k < last.sets_per_k);
        let tiny = RunConfig::preset("tiny", "LMS").unwrap();
        assert_eq!(tiny.cmf_settings(false), tiny.cmf_sim, "0 means as cmf_sim");
    }

    #[test]
    fn long_is_the_quick_eye_and_cortex_trained_to_their_plateau() {
        let quick = RunConfig::preset("quick", "LMS").unwrap();
        let long = RunConfig::preset("long", "LMS").unwrap();
        assert_eq!(
            (long.steps, long.cortex.train.steps),
            (LONG_STEPS, LONG_STEPS)
        );
        assert_eq!(long.retina, quick.retina);
        assert_eq!(
            (&long.cmf_sim, &long.observer),
            (&quick.cmf_sim, &quick.observer)
        );
        let mut cortex = long.cortex.clone();
        cortex.train.steps = quick.steps;
        cortex.train.checkpoint_every_steps = quick.cortex.train.checkpoint_every_steps;
        assert_eq!(cortex, quick.cortex);
        assert_eq!(long.cmf_settings(false), quick.cmf_settings(false));
        let e = RunConfig::preset("longer", "LMS").unwrap_err().to_string();
        assert!(
            e.contains("preset") && e.contains("`longer` is not one of tiny, quick, long"),
            "{e}"
        );
    }

    #[test]
    fn every_preset_resolves_and_round_trips_through_toml() {
        for preset in PRESETS {
            let c = RunConfig::preset(preset, "LMS").unwrap();
            c.validate().unwrap();
            let back: RunConfig = toml::from_str(&c.to_toml()).unwrap();
            assert_eq!(back, c, "{preset}");
        }
    }

    #[test]
    fn a_typo_in_a_config_file_names_the_file_and_the_field() {
        let dir = std::env::temp_dir().join(format!("cv_cfg_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("typo.toml");
        std::fs::write(
            &path,
            "preset = \"tiny\"\n[cortex.train]\nlearning_rat = 0.01\n",
        )
        .unwrap();
        let err = RunConfig::resolve(&options(Some(path.clone())), "quick")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("typo.toml") && err.contains("learning_rat"),
            "{err}"
        );
        std::fs::write(
            &path,
            "preset = \"tiny\"\nsteps = 7\n[cortex.train]\nlearning_rate = 0.01\n",
        )
        .unwrap();
        let c = RunConfig::resolve(&options(Some(path)), "quick").unwrap();
        assert_eq!(
            (c.steps, c.cortex.train.learning_rate, c.preset.as_str()),
            (7, 0.01, "tiny")
        );
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn command_line_overrides_the_file_and_mismatched_sizes_are_rejected() {
        let mut o = options(None);
        o.preset = Some("tiny".into());
        o.cones = Some("LM".into());
        o.steps = Some(5);
        let c = RunConfig::resolve(&o, "quick").unwrap();
        assert_eq!(
            (c.cones.as_str(), c.retina.cones.as_str(), c.steps),
            ("LM", "LM", 5)
        );
        let mut bad = c.clone();
        bad.cortex.ons_size_px = 64;
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("ons_size_px"));
    }

    #[test]
    fn every_seed_resolves_to_a_config_that_serialises() {
        for seed in [1, 2, 3, 12345, i64::MAX as u64] {
            let mut o = options(None);
            o.preset = Some("tiny".into());
            o.seed = Some(seed);
            let c = RunConfig::resolve(&o, "quick").unwrap();
            let back: RunConfig = toml::from_str(&c.to_toml()).unwrap();
            assert_eq!(back, c, "seed {seed}");
        }
        let mut o = options(None);
        o.seed = Some(u64::MAX);
        let e = RunConfig::resolve(&o, "quick").unwrap_err().to_string();
        assert!(e.contains("seed"), "{e}");
    }
}
