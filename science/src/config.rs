//! The resolved settings of a run: a preset, then a TOML file and `KEY=VALUE` settings, then
//! preset, cones, seed and steps given directly ([`Overrides`]), each overriding the last. Every
//! number is a config value; a preset is a named set of them.
//!
//! A TOML file may give any subset of the fields; unknown fields are errors that name the file
//! (or `--set`) and the field (a typo never silently does nothing). The resolved config is written into the
//! run folder as `config.toml`, so a run can be repeated with `--config runs/X/config.toml`.

use crate::observer::ObserverSettings;
use colorimetry::cmf_sim::CmfSimSettings;
use cortex::CortexConfig;
use retina::RetinaConfig;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod overrides;
mod presets;
mod ranges;
mod resolve;
mod unnamed;
mod validate;

pub use overrides::{parse_setting, set_dotted, Overrides, MEASUREMENT_SECTIONS};

pub use presets::{LONG_STEPS, MAIN_STEPS, PRESETS};

pub use ranges::{numeric_fields, range_of, Range, RANGES};
pub use resolve::{one_line, shortened, LONGEST_SHOWN};

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
    /// Held-out scenes of the hidden-signal figures and the own image in the run's summary and
    /// pictures at its end: [`crate::invariants::HELD_OUT_SCENES`], converged, in every preset
    /// but `tiny` ([`crate::invariants::TINY_HELD_OUT_SCENES`]); a config written before the
    /// setting existed reads 32, as such runs did.
    #[serde(default = "default_held_out_scenes")]
    pub held_out_scenes: usize,
}

/// What a run whose config predates `schedule.held_out_scenes` read (32 scenes).
fn default_held_out_scenes() -> usize {
    32
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
    /// A diagnostic, not a learning result: W starts at the eye's true lateral-inhibition
    /// kernel (read from the eye, which learning never does) instead of the identity. With
    /// `cortex.train.w_learning_rate_scale = 0` W is held there. Said in the run's output.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub oracle_w_start: bool,
    /// Credit assignment: a rule of the registry (`cortex::rule`): `backprop` (default),
    /// `feedback-alignment`, `kolen-pollack`, `direct-feedback-alignment`,
    /// `forward-forward`, or one the running binary registered.
    pub learning_rule: cortex::RuleName,
    /// The learning rule's settings (`[rule]`; each rule lists its own in `cortex::rule`).
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub rule: cortex::RuleSettings,
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

impl RunConfig {
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
mod tests;
