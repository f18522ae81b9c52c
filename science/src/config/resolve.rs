//! Resolving a [`RunConfig`]: a preset, then a TOML file and `--set` settings over it
//! (deep-merged; unknown fields are errors naming the file or `--set` and the field), then the
//! [`Overrides`] of preset, cones, seed and steps; the settings said twice reconciled, and every
//! component's seed derived from the run's seed.

use super::*;

impl RunConfig {
    /// Preset (from `--preset` or the file), file and `--set` overrides, then the other
    /// [`Overrides`].
    pub fn resolve(options: &Overrides, default_preset: &str) -> Result<RunConfig, ConfigError> {
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
        options: &Overrides,
        file: Option<(String, toml::Value)>,
        default_preset: &str,
    ) -> Result<RunConfig, ConfigError> {
        let file_alone = file.as_ref().map(|(_, v)| v.clone());
        let file = options.lay_settings_over(file)?;
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
                merge(&mut merged, value.clone());
                let laid = merged.try_into::<RunConfig>().map_err(|e| {
                    options
                        .setting_to_blame(&base, file_alone.as_ref())
                        .unwrap_or_else(|| ConfigError::Parse {
                            path: path.clone(),
                            message: one_line(&e.to_string()),
                        })
                })?;
                super::unnamed::check(&(path, value), &laid)?;
                laid
            }
            None => base,
        };
        config.preset = preset;
        config.cones = cones.clone();
        config.retina.cones = cones;
        if let Some(seed) = options.seed {
            config.seed = seed;
        }
        if let Some(scene) = &options.scene {
            config.retina.scenes.files = vec![scene.clone()];
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
            config.steps = steps;
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

/// Longest run of characters without a space that a message shows whole.
pub const LONGEST_SHOWN: usize = 80;

/// `message` with every word (run of characters without a space) longer than
/// [`LONGEST_SHOWN`] cut to its start and end around how many characters were left out: a
/// 100 000-character value is named, not echoed.
pub fn shortened(message: &str) -> String {
    message
        .split(' ')
        .map(|word| {
            let chars: Vec<char> = word.chars().collect();
            if chars.len() <= LONGEST_SHOWN {
                return word.to_string();
            }
            let head: String = chars[..48].iter().collect();
            let tail: String = chars[chars.len() - 16..].iter().collect();
            format!("{head}…[{} characters]…{tail}", chars.len() - 64)
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Names where a bad value came from: the command-line flag or `--set` that gave it, else the
/// config file.
fn attribute(e: ConfigError, options: &Overrides, file: Option<&str>) -> ConfigError {
    let ConfigError::Invalid { field, reason } = e else {
        return e;
    };
    if let Some(key) = options.set_key_of(&field) {
        return ConfigError::Invalid {
            field: format!("--set {key}"),
            reason,
        };
    }
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
pub(super) fn merge(base: &mut toml::Value, over: toml::Value) {
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
