//! Settings given on top of a preset and a config file ([`Overrides`]): the command line's
//! `--preset`, `--cones`, `--seed`, `--steps`, `--config FILE`, `--scene FILE` and
//! `--set KEY=VALUE`.
//!
//! `--set` reaches any key of a `--config` file, dotted (`cortex.train.learning_rate=3e-4`,
//! `retina.scenes.tetra.fraction=0.3`). The value is read as a TOML value (`3e-4`, `true`,
//! `"LMS"`, `[1, 2]`); one that is not TOML is taken as a string (`cones=LMSQ,Q:506`). The
//! settings given are laid over the file's as if they were written in it, the last given
//! winning, and validated as the file is: an unknown key or a value of the wrong type is an
//! error naming `--set` and the key, and a value out of range names `--set KEY`. The resolved
//! settings, and so every value given, are what a run writes into its `config.toml`.

use super::{one_line, ConfigError, RunConfig};
use std::path::PathBuf;

/// What is given on top of a preset, each optional; [`RunConfig::resolve`] applies them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    /// The preset (else the file's `preset`, else the caller's default).
    pub preset: Option<String>,
    /// The cone types (else the file's `cones`, else `LMS`).
    pub cones: Option<String>,
    /// The seed every component's seed derives from.
    pub seed: Option<u64>,
    /// Training steps.
    pub steps: Option<u64>,
    /// A TOML file of settings (any subset of a run's `config.toml`).
    pub config: Option<PathBuf>,
    /// Scenes from this file, folder or pattern (`[retina.scenes] files = [scene]`).
    pub scene: Option<PathBuf>,
    /// `KEY=VALUE` settings laid over the file's, in order (module docs).
    pub set: Vec<String>,
}

/// One `KEY=VALUE`, read: the dotted key and its value (module docs); an error names `--set`.
pub fn parse_setting(item: &str) -> Result<(String, toml::Value), ConfigError> {
    let bad = |message: String| ConfigError::Parse {
        path: "--set".into(),
        message,
    };
    let (key, raw) = item
        .split_once('=')
        .ok_or_else(|| bad(format!("`{item}`: expected KEY=VALUE, e.g. steps=2000")))?;
    let key = key.trim();
    let well_formed = |part: &str| {
        !part.is_empty()
            && part
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    if !key.split('.').all(well_formed) {
        return Err(bad(format!(
            "`{item}`: `{key}` is not a setting's dotted name (e.g. cortex.train.learning_rate)"
        )));
    }
    let raw = raw.trim();
    let value = toml::from_str::<toml::Table>(&format!("value = {raw}"))
        .ok()
        .and_then(|mut t| t.remove("value"))
        .unwrap_or_else(|| toml::Value::String(raw.to_string()));
    Ok((key.to_string(), value))
}

/// Sets `key` (dotted) to `value` in the table `root`, creating the tables on its way.
pub fn set_dotted(root: &mut toml::Value, key: &str, value: toml::Value) {
    let mut slot = root;
    for part in key.split('.') {
        if !slot.is_table() {
            *slot = toml::Value::Table(toml::Table::new());
        }
        let table = slot.as_table_mut().expect("made a table above");
        slot = table
            .entry(part)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    }
    *slot = value;
}

impl Overrides {
    /// The `--set` settings laid over `file` (a config file's name and settings, or none),
    /// in order; `None` when neither is given.
    pub(super) fn lay_settings_over(
        &self,
        file: Option<(String, toml::Value)>,
    ) -> Result<Option<(String, toml::Value)>, ConfigError> {
        if self.set.is_empty() {
            return Ok(file);
        }
        let (name, mut value) =
            file.unwrap_or_else(|| ("--set".into(), toml::Value::Table(toml::Table::new())));
        for item in &self.set {
            let (key, setting) = parse_setting(item)?;
            set_dotted(&mut value, &key, setting);
        }
        Ok(Some((name, value)))
    }

    /// The `--set` setting to name when the settings laid over `base` (the preset) and `file`
    /// (the `--config` file's own settings) did not parse: the first whose removal lets the
    /// rest parse, else the first that does not parse laid alone. `None` when the preset and the
    /// file do not parse without any setting (the file's error) or no setting is singled out.
    /// Settings that make a table together (`retina.scenes.tetra.environment` and `.fraction`)
    /// are judged together, never one without the other.
    pub(super) fn setting_to_blame(
        &self,
        base: &RunConfig,
        file: Option<&toml::Value>,
    ) -> Option<ConfigError> {
        let mut start = toml::Value::try_from(base).expect("a RunConfig serialises to TOML");
        if let Some(file) = file {
            super::resolve::merge(&mut start, file.clone());
        }
        let parses = |v: toml::Value| v.try_into::<RunConfig>().map_err(|e| e.to_string());
        parses(start.clone()).ok()?;
        let settings: Vec<(String, toml::Value)> =
            match self.set.iter().map(|i| parse_setting(i)).collect() {
                Ok(settings) => settings,
                Err(e) => return Some(e),
            };
        let laid = |skip: Option<usize>, only: Option<usize>| {
            let mut v = start.clone();
            for (i, (key, value)) in settings.iter().enumerate() {
                if skip != Some(i) && only.is_none_or(|o| o == i) {
                    set_dotted(&mut v, key, value.clone());
                }
            }
            parses(v)
        };
        let whole = laid(None, None).err()?;
        let named = |i: usize, message: String| ConfigError::Parse {
            path: format!("--set {}", self.set[i]),
            message: one_line(&message),
        };
        for i in 0..settings.len() {
            if laid(Some(i), None).is_ok() {
                return Some(named(i, laid(None, Some(i)).err().unwrap_or(whole)));
            }
        }
        (0..settings.len()).find_map(|i| laid(None, Some(i)).err().map(|e| named(i, e)))
    }

    /// The `--set` key that gave `field` (a setting's dotted name), if one did.
    pub(super) fn set_key_of(&self, field: &str) -> Option<String> {
        self.set.iter().rev().find_map(|item| {
            let (key, _) = parse_setting(item).ok()?;
            let gave = field == key || field.starts_with(&format!("{key}."));
            gave.then_some(key)
        })
    }
}

/// The sections of a run's settings that a measurement of its trained cortex may change:
/// CMF-SIM's budget and draws (`cmf_sim.*`) and how the observer shows lights and reads the
/// percept (`observer.*`). The eye, the cortex and the training are the run's own.
pub const MEASUREMENT_SECTIONS: [&str; 2] = ["cmf_sim", "observer"];

impl RunConfig {
    /// `settings` (`KEY=VALUE`, read as `--set` reads them) laid over these settings, for a
    /// measurement of a trained run. A key outside [`MEASUREMENT_SECTIONS`] is refused, naming
    /// `--set` and the key: it would measure a cortex through an eye it was not trained on. The
    /// result is validated as a resolved run's is.
    pub fn with_measurement_settings(&self, settings: &[String]) -> Result<RunConfig, ConfigError> {
        if settings.is_empty() {
            return Ok(self.clone());
        }
        let mut value = toml::Value::try_from(self).expect("a RunConfig serialises to TOML");
        for item in settings {
            let (key, setting) = parse_setting(item)?;
            let section = key.split('.').next().unwrap_or_default();
            if !MEASUREMENT_SECTIONS.contains(&section) || !key.contains('.') {
                return Err(ConfigError::Parse {
                    path: format!("--set {item}"),
                    message: format!(
                        "`{key}` is a setting of the trained run, which a measurement keeps; \
                         only `cmf_sim.*` and `observer.*` may be set here"
                    ),
                });
            }
            set_dotted(&mut value, &key, setting);
        }
        let config: RunConfig =
            value
                .try_into()
                .map_err(|e: toml::de::Error| ConfigError::Parse {
                    path: format!("--set {}", settings.join(" --set ")),
                    message: one_line(&e.to_string()),
                })?;
        config.validate()?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_is_read_as_toml_and_else_as_a_string() {
        let read = |s: &str| parse_setting(s).unwrap();
        assert_eq!(
            read("cortex.train.learning_rate=3e-4"),
            (
                "cortex.train.learning_rate".into(),
                toml::Value::Float(3e-4)
            )
        );
        assert_eq!(
            read("steps = 200"),
            ("steps".into(), toml::Value::Integer(200))
        );
        assert_eq!(read("oracle_motion=false").1, toml::Value::Boolean(false));
        assert_eq!(
            read("cones=LMSQ,Q:506").1,
            toml::Value::String("LMSQ,Q:506".into())
        );
        assert_eq!(read("cones=\"LM\"").1, toml::Value::String("LM".into()));
        for bad in ["steps", "=3", "cortex..train=1", "a b=1"] {
            let e = parse_setting(bad).unwrap_err().to_string();
            assert!(
                e.starts_with("--set: ") && e.contains(bad.trim()),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn a_dotted_key_makes_the_tables_on_its_way() {
        let mut root = toml::Value::Table(toml::Table::new());
        set_dotted(&mut root, "a.b.c", toml::Value::Integer(1));
        set_dotted(&mut root, "a.d", toml::Value::Integer(2));
        assert_eq!(root["a"]["b"]["c"].as_integer(), Some(1));
        assert_eq!(root["a"]["d"].as_integer(), Some(2));
    }

    #[test]
    fn a_measurement_may_set_cmf_sim_and_observer_and_nothing_else() {
        let base = RunConfig::preset("tiny", "LMS").unwrap();
        let set = |items: &[&str]| {
            let items: Vec<String> = items.iter().map(|s| s.to_string()).collect();
            base.with_measurement_settings(&items)
        };
        let measured = set(&["cmf_sim.sets_per_k=7", "observer.decode_batch=3"]).unwrap();
        assert_eq!(measured.cmf_sim.sets_per_k, 7);
        assert_eq!(measured.observer.decode_batch, 3);
        assert_eq!(measured.retina, base.retina);
        assert_eq!(measured.cortex, base.cortex);
        assert_eq!(set(&[]).unwrap(), base);
        for refused in [
            "retina.noise=false",
            "cortex.train.learning_rate=1",
            "steps=3",
            "cmf_sim=1",
        ] {
            let e = set(&[refused]).unwrap_err().to_string();
            assert!(e.contains(refused) && e.contains("keeps"), "{refused}: {e}");
        }
        let e = set(&["cmf_sim.no_such_key=1"]).unwrap_err().to_string();
        assert!(e.contains("no_such_key"), "{e}");
        let e = set(&["cmf_sim.sets_per_k=0"]).unwrap_err().to_string();
        assert!(e.contains("sets_per_k"), "{e}");
    }
}
