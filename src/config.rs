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

impl RunConfig {
    /// The named preset with `cones`.
    pub fn preset(name: &str, cones: &str) -> Result<RunConfig, ConfigError> {
        let invalid = |reason: String| ConfigError::Invalid {
            field: "preset".into(),
            reason,
        };
        let mut retina = RetinaConfig::preset(name).map_err(|e| invalid(e.to_string()))?;
        retina.cones = cones.to_string();
        let mut cortex = CortexConfig::preset(name).map_err(|e| invalid(e.to_string()))?;
        if name == "quick" {
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
            // quick: CMF-SIM at the end with a paper-like budget (100 wavelengths, 8 location
            // pairs as the authors' code, docs/references.md#cmf-sim-defaults; 100 sets per K,
            // the paper used 500): 1.5–4 min on a trained quick cortex. During training a
            // smaller budget (below) draws the dimension over steps (Fig. 3.3).
            _ => (6000, 1500, 100, 100, 8),
        };
        // Early measurements catch the growth of the dimension (paper Fig. 3.3: 1-D, 2-D, 3-D).
        let extra_steps = match name {
            "quick" => vec![50, 100, 250, 500],
            _ => Vec::new(),
        };
        // The budget during training: each measurement should stay near a minute. 30 sets per
        // K: with 5, a quick MS dichromat's K = 2 failed by chance (its 10th set passed): too
        // few sets overstate the dimension.
        let (checkpoint_sets, checkpoint_wavelengths, checkpoint_pairs) = match name {
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

    /// Preset (from `--preset` or the file), file overrides, then command-line options.
    pub fn resolve(
        options: &CommonOptions,
        default_preset: &str,
    ) -> Result<RunConfig, ConfigError> {
        let file = match &options.config {
            Some(path) => {
                let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
                    path: path.clone(),
                    source,
                })?;
                let value: toml::Value = toml::from_str(&text).map_err(|e| ConfigError::Parse {
                    path: path.display().to_string(),
                    message: one_line(&e.to_string()),
                })?;
                Some((path.display().to_string(), value))
            }
            None => None,
        };
        RunConfig::resolve_value(options, file, default_preset)
    }

    /// [`RunConfig::resolve`] with the config file already read: `file` is its name (as errors
    /// name it) and its settings (any subset of the fields, as in a `--config` file).
    pub fn resolve_value(
        options: &CommonOptions,
        file: Option<(String, toml::Value)>,
        default_preset: &str,
    ) -> Result<RunConfig, ConfigError> {
        let file_str = |key: &str| {
            file.as_ref()
                .and_then(|(_, v)| v.get(key))
                .and_then(|v| v.as_str())
                .map(str::to_string)
        };
        let preset = options
            .preset
            .clone()
            .or_else(|| file_str("preset"))
            .unwrap_or_else(|| default_preset.to_string());
        let cones = options
            .cones
            .clone()
            .or_else(|| file_str("cones"))
            .unwrap_or_else(|| "LMS".to_string());
        let base = RunConfig::preset(&preset, &cones)?;
        let given = |key: &[&str]| {
            file.as_ref()
                .is_some_and(|(_, v)| key.iter().try_fold(v, |v, k| v.get(k)).is_some())
        };
        let keys = FileKeys {
            steps: given(&["steps"]),
            train_steps: given(&["cortex", "train", "steps"]),
            oracle_motion: given(&["oracle_motion"]),
            m_mode: given(&["cortex", "m", "mode"]),
        };
        let file_path = file.as_ref().map(|(p, _)| p.clone());
        let mut config = match file {
            Some((path, value)) => {
                let mut merged =
                    toml::Value::try_from(&base).expect("a RunConfig serialises to TOML");
                merge(&mut merged, value);
                merged
                    .try_into::<RunConfig>()
                    .map_err(|e| ConfigError::Parse {
                        path,
                        message: one_line(&e.to_string()),
                    })?
            }
            None => base,
        };
        config.preset = preset;
        config.cones = cones.clone();
        config.retina.cones = cones;
        if let Some(seed) = options.seed {
            config.seed = seed;
        }
        let in_file = |field: &str, reason: String| match &file_path {
            Some(path) => ConfigError::InFile {
                path: path.clone(),
                field: field.into(),
                reason,
            },
            None => ConfigError::Invalid {
                field: field.into(),
                reason,
            },
        };
        config.reconcile(&keys).map_err(|(f, r)| in_file(f, r))?;
        if let Some(steps) = options.steps {
            config.steps = steps as u64;
        }
        config.cortex.train.steps = config.steps;
        config.apply_seed();
        config
            .validate()
            .map_err(|e| attribute(e, options, file_path.as_deref()))?;
        Ok(config)
    }

    /// Settings said twice are made one: `[cortex.train] steps` is `steps` (they must agree
    /// when both are given), and `oracle_motion` follows `[cortex.m] mode` (and the other way
    /// round) when only one of them is given. Errors name the field.
    fn reconcile(&mut self, keys: &FileKeys) -> Result<(), (&'static str, String)> {
        if keys.train_steps {
            if keys.steps && self.steps != self.cortex.train.steps {
                return Err((
                    "cortex.train.steps",
                    format!(
                        "{} disagrees with `steps` = {} (they are one setting; give one)",
                        self.cortex.train.steps, self.steps
                    ),
                ));
            }
            self.steps = self.cortex.train.steps;
        }
        let oracle_mode = cortex::config::MMode::Oracle;
        match (keys.oracle_motion, keys.m_mode) {
            (false, true) => self.oracle_motion = self.cortex.m.mode == oracle_mode,
            (true, false) if self.oracle_motion => self.cortex.m.mode = oracle_mode,
            (true, false) if self.cortex.m.mode == oracle_mode => {
                return Err((
                    "oracle_motion",
                    "false needs an estimated eye motion: set [cortex.m] mode = \"learned\" \
                     (or \"block_matching\") as well"
                        .into(),
                ))
            }
            _ => {}
        }
        Ok(())
    }

    /// Derives every component's seed from `seed` (seed 0 keeps the presets' official seeds).
    fn apply_seed(&mut self) {
        if self.seed == 0 {
            return;
        }
        let s = self.seed;
        // Derived seeds keep 63 bits: TOML integers are signed 64-bit, and every seed is
        // written to the run's config.toml.
        let derive = |k: u64| s.wrapping_mul(k) >> 1;
        self.retina.mosaic_seed = derive(0x9E37_79B9_7F4A_7C15);
        self.retina.layout_seed = derive(0xC2B2_AE3D_27D4_EB4F);
        self.retina.scene_seed = derive(0x1656_67B1_9E37_79F9);
        self.cortex.train.seed = derive(0x27D4_EB2F_1656_67C5);
        self.cmf_sim.seed = s;
    }

    /// Checks values that must agree across components.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let invalid = |field: &str, reason: String| ConfigError::Invalid {
            field: field.into(),
            reason,
        };
        self.validate_said_twice()?;
        if self.retina.cones_per_side != self.cortex.ons_size_px {
            return Err(invalid(
                "cortex.ons_size_px",
                format!(
                    "{} but the retina has {} cones per side",
                    self.cortex.ons_size_px, self.retina.cones_per_side
                ),
            ));
        }
        self.retina.validate().map_err(|e| match e {
            retina::RetinaError::InvalidSetting { name, message } => {
                invalid(&format!("retina.{name}"), message)
            }
            other => invalid("retina", other.to_string()),
        })?;
        self.cortex.validate().map_err(|e| match e {
            cortex::CortexError::InvalidConfig { field, reason } => {
                invalid(&format!("cortex.{field}"), reason)
            }
            other => invalid("cortex", other.to_string()),
        })?;
        if self.steps == 0 {
            return Err(invalid("steps", "must be at least 1".into()));
        }
        self.observer.validate()?;
        let grid = self
            .retina
            .grid
            .grid()
            .map_err(|e| invalid("retina.grid", e.to_string()))?;
        for (what, s) in [
            ("cmf_sim", self.cmf_sim.clone()),
            ("schedule.checkpoint_cmf", self.cmf_settings(false)),
        ] {
            colorimetry::cmf_sim::validate_settings(&s, &grid).map_err(|e| match e {
                colorimetry::ColorimetryError::InvalidSetting { name, message } => {
                    invalid(&format!("{what}.{name}"), message)
                }
                other => invalid(what, other.to_string()),
            })?;
        }
        // Every value is written to config.toml, whose integers are signed 64-bit.
        for (field, v) in [
            ("seed", self.seed),
            ("steps", self.steps),
            ("retina.mosaic_seed", self.retina.mosaic_seed),
            ("retina.layout_seed", self.retina.layout_seed),
            ("retina.scene_seed", self.retina.scene_seed),
            ("cortex.train.seed", self.cortex.train.seed),
            ("cmf_sim.seed", self.cmf_sim.seed),
        ] {
            if v > i64::MAX as u64 {
                return Err(invalid(
                    field,
                    format!("{v} exceeds {} (TOML integers are signed 64-bit)", i64::MAX),
                ));
            }
        }
        Ok(())
    }

    /// Checks that settings said in two places agree (`oracle_motion` and `[cortex.m] mode`,
    /// `steps` and `[cortex.train] steps`, `cones` and `[retina] cones`) and that the mosaic
    /// parses.
    fn validate_said_twice(&self) -> Result<(), ConfigError> {
        let invalid = |field: &str, reason: String| ConfigError::Invalid {
            field: field.into(),
            reason,
        };
        if self.oracle_motion != (self.cortex.m.mode == cortex::config::MMode::Oracle) {
            return Err(invalid(
                "oracle_motion",
                format!(
                    "{} but [cortex.m] mode = {:?}: the oracle motion is mode \"oracle\"",
                    self.oracle_motion, self.cortex.m.mode
                ),
            ));
        }
        if self.cortex.train.steps != self.steps {
            return Err(invalid(
                "cortex.train.steps",
                format!(
                    "{} disagrees with `steps` = {} (they are one setting)",
                    self.cortex.train.steps, self.steps
                ),
            ));
        }
        if self.retina.cones != self.cones {
            return Err(invalid(
                "retina.cones",
                format!(
                    "`{}` disagrees with `cones` = `{}`",
                    self.retina.cones, self.cones
                ),
            ));
        }
        retina::MosaicSpec::parse(&self.cones).map_err(|e| match e {
            retina::RetinaError::InvalidSetting { message, .. } => {
                invalid("cones", format!("`{}`: {message}", self.cones))
            }
            other => invalid("cones", other.to_string()),
        })?;
        Ok(())
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

/// The TOML parser's message on one line: the source excerpt it draws (lines of `|`) is
/// dropped, the rest joined (`… at line 1, column 9: invalid string; expected `"``).
pub fn one_line(message: &str) -> String {
    let mut out = String::new();
    for line in message.lines().map(str::trim) {
        let excerpt = line.starts_with('|')
            || line
                .split_once(" |")
                .is_some_and(|(n, _)| n.chars().all(|c| c.is_ascii_digit()));
        if line.is_empty() || excerpt {
            continue;
        }
        if !out.is_empty() {
            out.push_str(if line.starts_with("in `") { " " } else { ": " });
        }
        out.push_str(line);
    }
    out
}

/// Names where a bad value came from: the command-line flag that set it, else the config file.
fn attribute(e: ConfigError, options: &CommonOptions, file: Option<&str>) -> ConfigError {
    let ConfigError::Invalid { field, reason } = e else {
        return e;
    };
    let flag = match field.as_str() {
        "steps" if options.steps.is_some() => Some("--steps"),
        "cones" if options.cones.is_some() => Some("--cones"),
        "seed" if options.seed.is_some() => Some("--seed"),
        _ => None,
    };
    match (flag, file) {
        (Some(flag), _) => ConfigError::Invalid {
            field: flag.into(),
            reason,
        },
        (None, Some(path)) => ConfigError::InFile {
            path: path.into(),
            field,
            reason,
        },
        (None, None) => ConfigError::Invalid { field, reason },
    }
}

/// Which of the settings said twice a config file gave.
struct FileKeys {
    steps: bool,
    train_steps: bool,
    oracle_motion: bool,
    m_mode: bool,
}

/// Deep-merges `over` into `base` (tables recursively, everything else replaced).
fn merge(base: &mut toml::Value, over: toml::Value) {
    match (base, over) {
        (toml::Value::Table(b), toml::Value::Table(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(config: Option<PathBuf>) -> CommonOptions {
        CommonOptions {
            preset: None,
            cones: None,
            seed: None,
            steps: None,
            out: None,
            config,
            resume: false,
            force: false,
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
    fn every_preset_resolves_and_round_trips_through_toml() {
        for preset in ["tiny", "quick", "sandbox", "paper"] {
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
