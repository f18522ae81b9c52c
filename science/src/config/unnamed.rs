//! A whole run config (a run's `config.toml`) must mean the same laid over its preset as it
//! means alone.
//!
//! A `--config` file is laid over today's preset, so a key it does not name takes the preset's
//! value. For a hand-written subset of settings that is the point. For a run's `config.toml`
//! written before a setting existed it silently changes the run: the file, read alone as its run
//! reads it, gives the setting its serde default (a record made before surface scenes means dead
//! leaves; one made before P's log-scale bound means no bound), while laid over the `main`
//! preset it takes today's value (surfaces; a bound of 2). [`check`] refuses such a file before
//! any work starts, naming each setting the two readings disagree on and both values, so that
//! the user names it (`--set KEY=VALUE`). A file that does not read alone (a subset) is not
//! checked.

use super::{ConfigError, RunConfig};

/// Settings named in the error at most (the rest are counted).
const NAMED_AT_MOST: usize = 4;

/// `Ok` unless `file` (its name and its settings, `--set` laid over it) reads alone as a whole
/// [`RunConfig`] that differs from `laid`, the same settings laid over the preset.
pub(super) fn check(file: &(String, toml::Value), laid: &RunConfig) -> Result<(), ConfigError> {
    let Ok(alone) = file.1.clone().try_into::<RunConfig>() else {
        return Ok(());
    };
    let as_value =
        |c: &RunConfig| toml::Value::try_from(c).expect("a RunConfig serialises to TOML");
    let mut differ = Vec::new();
    leaves_that_differ("", &as_value(&alone), &as_value(laid), &mut differ);
    if differ.is_empty() {
        return Ok(());
    }
    let named: Vec<String> = differ
        .iter()
        .take(NAMED_AT_MOST)
        .map(|(key, alone, laid)| format!("{key} (alone {alone}, over the preset {laid})"))
        .collect();
    let more = differ.len().saturating_sub(NAMED_AT_MOST);
    Err(ConfigError::InFile {
        path: file.0.clone(),
        field: differ[0].0.clone(),
        reason: format!(
            "a whole run config that does not name every setting: read alone, as its run reads \
             it, it differs from the same file laid over the preset `{}` in {}{}; name each \
             with --set KEY=VALUE (the value its run had is the one read alone)",
            laid.preset,
            named.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ),
    })
}

/// Appends `(dotted key, value in a, value in b)` for every leaf where `a` and `b` differ
/// (tables compared key by key; a key missing on one side shows as `none` there).
fn leaves_that_differ(
    prefix: &str,
    a: &toml::Value,
    b: &toml::Value,
    out: &mut Vec<(String, String, String)>,
) {
    match (a, b) {
        (toml::Value::Table(ta), toml::Value::Table(tb)) => {
            let mut keys: Vec<&String> = ta.keys().chain(tb.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match (ta.get(k), tb.get(k)) {
                    (Some(va), Some(vb)) => leaves_that_differ(&key, va, vb, out),
                    (va, vb) => out.push((key, shown(va), shown(vb))),
                }
            }
        }
        _ if a != b => out.push((prefix.to_string(), shown(Some(a)), shown(Some(b)))),
        _ => {}
    }
}

/// A value as TOML writes it, `none` for a missing one.
fn shown(v: Option<&toml::Value>) -> String {
    v.map_or_else(|| "none".to_string(), |v| v.to_string())
}

#[cfg(test)]
mod tests {
    use super::super::Overrides;
    use super::*;
    use retina::scene::pool::SceneGenerator;

    /// The `main` preset's whole config as a run writes it, without the dotted `keys` (as a
    /// record made before they existed).
    fn record_without(keys: &[&str]) -> toml::Value {
        let mut v = toml::Value::try_from(RunConfig::preset("main", "LMS").unwrap()).unwrap();
        for key in keys {
            let (path, last) = key.rsplit_once('.').unwrap();
            let table = path.split('.').fold(&mut v, |v, k| v.get_mut(k).unwrap());
            table.as_table_mut().unwrap().remove(last).unwrap();
        }
        v
    }

    fn resolve(file: toml::Value, set: &[&str]) -> Result<RunConfig, ConfigError> {
        let options = Overrides {
            set: set.iter().map(|s| s.to_string()).collect(),
            ..Overrides::default()
        };
        RunConfig::resolve_value(&options, Some(("old/config.toml".into(), file)), "main")
    }

    /// A record without the generator and P's bound reads alone as dead leaves and no bound,
    /// laid over `main` as surfaces and 2: refused, naming the file, both settings and their
    /// two values.
    #[test]
    fn a_whole_config_missing_settings_whose_meaning_changed_is_refused() {
        let old = record_without(&["retina.scenes.generator", "cortex.p.log_scale_bound"]);
        let err = resolve(old, &[]).unwrap_err().to_string();
        for want in [
            "old/config.toml",
            "cortex.p.log_scale_bound (alone none, over the preset 2.0)",
            "retina.scenes.generator (alone \"dead_leaves\", over the preset \"surfaces\")",
        ] {
            assert!(err.contains(want), "{want:?} not in: {err}");
        }
    }

    /// Naming them with `--set` resolves, to the values given.
    #[test]
    fn naming_the_settings_resolves() {
        let old = record_without(&["retina.scenes.generator", "cortex.p.log_scale_bound"]);
        let set = [
            "retina.scenes.generator=dead_leaves",
            "cortex.p.log_scale_bound=2.0",
        ];
        let c = resolve(old, &set).unwrap();
        assert_eq!(c.retina.scenes.generator, SceneGenerator::DeadLeaves);
        assert_eq!(c.cortex.p.log_scale_bound, Some(2.0));
    }

    /// A whole config that names everything, and a subset of settings, resolve as before.
    #[test]
    fn whole_configs_and_subsets_are_not_refused() {
        let whole = resolve(record_without(&[]), &[]).unwrap();
        assert_eq!(
            whole,
            RunConfig::resolve_value(&Overrides::default(), None, "main").unwrap()
        );
        let subset: toml::Value = toml::from_str("[cortex.train]\nlearning_rate = 3e-4\n").unwrap();
        assert_eq!(
            resolve(subset, &[]).unwrap().cortex.train.learning_rate,
            3e-4
        );
    }
}
