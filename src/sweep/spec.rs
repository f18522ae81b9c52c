//! A sweep spec: a TOML file naming a grid of settings, every combination of which is one run.
//!
//! ```toml
//! max_runs = 100              # optional (default 1000): a larger grid is refused
//! command = "run"             # optional: "run" (CMF-SIM measured; default) or "train"
//!
//! [base]                      # optional: the settings of every run, as in a --config file
//! preset = "tiny"
//! steps = 200
//!
//! [grid]                      # one list of values per setting; every combination is a run
//! cones = ["LMS", "LM"]
//! seed = [0, 1, 2]
//! learning_rule = ["backprop", "feedback-alignment"]
//! "cortex.train.learning_rate" = [1e-3, 3e-3]   # a dotted key reaches into a table
//!
//! [slurm]                     # optional: see [`super::script::SlurmSettings`]
//! concurrency = 2
//! ```
//!
//! Grid keys are taken in alphabetical order (the TOML reader sorts them) and the last one
//! varies fastest: run `i` is the `i`-th combination in that order, and Slurm array task `i`.
//! Each run's settings are the preset, then `[base]`, then its grid values, resolved by
//! [`RunConfig::resolve_value`] exactly as a `--config` file would be: an unknown key, a value
//! of the wrong type or out of range is an error naming the spec file and the grid key.

use super::script::SlurmSettings;
use science::config::{one_line, set_dotted, ConfigError, Overrides, RunConfig};
use serde::Deserialize;
use std::path::Path;

/// Runs a spec may expand to unless it sets `max_runs`.
pub const DEFAULT_MAX_RUNS: usize = 1000;

/// The spec file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    #[serde(default = "default_max_runs")]
    max_runs: usize,
    #[serde(default = "default_command")]
    command: String,
    #[serde(default)]
    base: toml::Table,
    #[serde(default)]
    grid: toml::Table,
    #[serde(default)]
    slurm: SlurmSettings,
}

fn default_max_runs() -> usize {
    DEFAULT_MAX_RUNS
}

fn default_command() -> String {
    "run".into()
}

/// One setting of the grid and the values it takes.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Dotted key, e.g. `cortex.train.learning_rate`.
    pub key: String,
    /// Its values, in the order written.
    pub values: Vec<toml::Value>,
}

/// One run of the sweep.
#[derive(Clone, Debug)]
pub struct Job {
    /// Its index: the Slurm array task id.
    pub index: usize,
    /// Its folder name inside the sweep folder.
    pub folder: String,
    /// Its grid values, one per axis.
    pub settings: Vec<(String, toml::Value)>,
    /// Its resolved settings.
    pub config: RunConfig,
}

/// A spec expanded: every run resolved, nothing written yet.
#[derive(Clone, Debug)]
pub struct Expanded {
    /// `run` (CMF-SIM measured) or `train`.
    pub command: String,
    /// The grid.
    pub axes: Vec<Axis>,
    /// One per run, in array-task order.
    pub jobs: Vec<Job>,
    /// Job-array requests given by the spec.
    pub slurm: SlurmSettings,
}

/// An error in the spec file `path` at `key`.
pub fn spec_error(path: &Path, key: &str, reason: impl std::fmt::Display) -> ConfigError {
    ConfigError::Parse {
        path: path.display().to_string(),
        message: format!("`{key}`: {reason}"),
    }
}

/// Reads and expands the spec at `path`; every run's settings are resolved and checked.
pub fn expand(path: &Path) -> Result<Expanded, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let spec = read_spec(path, &text)?;
    if !matches!(spec.command.as_str(), "run" | "train") {
        return Err(spec_error(path, "command", "must be \"run\" or \"train\""));
    }
    spec.slurm.validate(path)?;
    let mut axes = Vec::new();
    flatten_grid(path, &spec.grid, "grid", &mut axes)?;
    if axes.is_empty() {
        return Err(spec_error(
            path,
            "grid",
            "empty grid: give at least one setting with a list of values, e.g. seed = [0, 1]",
        ));
    }
    let runs = axes
        .iter()
        .try_fold(1usize, |n, a| n.checked_mul(a.values.len()))
        .unwrap_or(usize::MAX);
    if runs > spec.max_runs {
        let sizes: Vec<String> = axes.iter().map(|a| a.values.len().to_string()).collect();
        return Err(spec_error(
            path,
            "max_runs",
            format!(
                "the grid has {runs} runs ({}), more than max_runs = {}: shrink the grid or \
                 raise max_runs",
                sizes.join(" × "),
                spec.max_runs
            ),
        ));
    }
    let base = toml::Value::Table(spec.base);
    resolve(path, &base, &[]).map_err(|e| labelled(path, "[base]", e))?;
    // Each value alone first, so an error names the one key and value that caused it.
    for axis in &axes {
        for v in &axis.values {
            let one = [(axis.key.clone(), v.clone())];
            resolve(path, &base, &one).map_err(|e| labelled(path, &grid_key(&axis.key, v), e))?;
        }
    }
    let width = (runs - 1).to_string().len().max(3);
    let mut jobs = Vec::with_capacity(runs);
    for index in 0..runs {
        let settings = combination(&axes, index);
        let config = resolve(path, &base, &settings).map_err(|e| {
            let keys: Vec<String> = settings.iter().map(|(k, v)| grid_key(k, v)).collect();
            labelled(path, &format!("run {index}: {}", keys.join(", ")), e)
        })?;
        jobs.push(Job {
            index,
            folder: folder_name(index, width, &settings),
            settings,
            config,
        });
    }
    Ok(Expanded {
        command: spec.command,
        axes,
        jobs,
        slurm: spec.slurm,
    })
}

/// Parses the spec; a wrong value names its key (`slurm.…` inside `[slurm]`).
fn read_spec(path: &Path, text: &str) -> Result<SpecFile, ConfigError> {
    let table: toml::Table = toml::from_str(text).map_err(|e| ConfigError::Parse {
        path: path.display().to_string(),
        message: one_line(&e.to_string()),
    })?;
    // Each key alone, so the error names the key (the parser's message names only a line).
    for (key, value) in &table {
        let alone = toml::Value::Table(toml::Table::from_iter([(key.clone(), value.clone())]));
        let Err(e) = alone.try_into::<SpecFile>() else {
            continue;
        };
        let mut name = key.clone();
        if let (Some(slurm), "slurm") = (value.as_table(), key.as_str()) {
            for (k, v) in slurm {
                let one = toml::Value::Table(toml::Table::from_iter([(k.clone(), v.clone())]));
                if one.try_into::<SlurmSettings>().is_err() {
                    name = format!("slurm.{k}");
                    break;
                }
            }
        }
        return Err(spec_error(path, &name, one_line(&e.to_string())));
    }
    toml::Value::Table(table)
        .try_into()
        .map_err(|e| spec_error(path, "(spec)", one_line(&e.to_string())))
}

fn grid_key(key: &str, value: &toml::Value) -> String {
    format!("[grid] {key} = {value}")
}

/// Collects the lists of `grid` (tables nest: `[grid.cortex.train]` is `cortex.train.…`).
fn flatten_grid(
    path: &Path,
    grid: &toml::Table,
    prefix: &str,
    axes: &mut Vec<Axis>,
) -> Result<(), ConfigError> {
    for (k, v) in grid {
        let shown = format!("{prefix}.{k}");
        let key = shown.trim_start_matches("grid.").to_string();
        match v {
            toml::Value::Array(values) if values.is_empty() => {
                return Err(spec_error(
                    path,
                    &shown,
                    "empty list: give at least one value",
                ))
            }
            toml::Value::Array(values) => axes.push(Axis {
                key,
                values: values.clone(),
            }),
            toml::Value::Table(t) => flatten_grid(path, t, &shown, axes)?,
            other => {
                return Err(spec_error(
                    path,
                    &shown,
                    format!(
                        "a {} where a list of values belongs: write {k} = [{other}] for one value",
                        other.type_str()
                    ),
                ))
            }
        }
    }
    Ok(())
}

/// The settings of run `index`: the last axis varies fastest.
fn combination(axes: &[Axis], mut index: usize) -> Vec<(String, toml::Value)> {
    let mut out = vec![(String::new(), toml::Value::Boolean(false)); axes.len()];
    for (slot, axis) in out.iter_mut().zip(axes).rev() {
        let n = axis.values.len();
        *slot = (axis.key.clone(), axis.values[index % n].clone());
        index /= n;
    }
    out
}

/// Resolves `base` with `settings` set on top, as a `--config` file named `path` would be.
fn resolve(
    path: &Path,
    base: &toml::Value,
    settings: &[(String, toml::Value)],
) -> Result<RunConfig, ConfigError> {
    let mut file = base.clone();
    for (key, value) in settings {
        set_dotted(&mut file, key, value.clone());
    }
    RunConfig::resolve_value(
        &Overrides::default(),
        Some((path.display().to_string(), file)),
        "quick",
    )
}

/// Prefixes the spec location `what` to a resolution error (which names the setting).
fn labelled(path: &Path, what: &str, e: ConfigError) -> ConfigError {
    let file = path.display().to_string();
    let strip = |s: String| {
        s.strip_prefix(&format!("{file}: "))
            .map(str::to_string)
            .unwrap_or(s)
    };
    ConfigError::Parse {
        path: file.clone(),
        message: format!("{what}: {}", strip(e.to_string())),
    }
}

/// `007_cones=LM_seed=1`: the index, then each grid value under its key's last part.
fn folder_name(index: usize, width: usize, settings: &[(String, toml::Value)]) -> String {
    let mut name = format!("{index:0width$}");
    for (key, value) in settings {
        let short = key.rsplit('.').next().unwrap_or(key);
        let text = match value {
            toml::Value::String(s) => s.clone(),
            other => other.to_string(),
        };
        let safe: String = text
            .chars()
            .take(24)
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '.' | '+' | '-') {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        name.push_str(&format!("_{short}={safe}"));
    }
    name
}

#[cfg(test)]
#[path = "spec_tests.rs"]
mod tests;
