//! A run folder belongs to one run. [`open`] decides, before any work, whether `--out` is new,
//! the same run to continue (`--resume`), the same run already finished, or someone else's:
//! a folder holding a different run (or not a run at all) is refused, never mixed; `--force`
//! empties a run folder first. [`load_run`] reads a run back: its config and newest checkpoint
//! that verifies.

use crate::io::{fs_err, IoError};
use crate::run::error::RunError;
use crate::run::lock::LOCK_FILE;
use cortex::Trainer;
use science::config::RunConfig;
use std::path::{Path, PathBuf};

/// What to do with a run folder that already holds files.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Folder {
    /// Refuse a folder that holds files (`--out` must be new or empty).
    #[default]
    New,
    /// Continue the run the folder holds (`--resume`); it must be the same run. An empty or
    /// absent folder starts the run.
    Resume,
    /// Empty the folder first (`--force`); it must be a run folder.
    Replace,
}

/// What [`open`] found.
#[derive(Debug, PartialEq, Eq)]
pub enum Opened {
    /// Start from step 0 (the folder is absent or empty, or was emptied).
    Fresh,
    /// Continue the run in the folder from its newest valid checkpoint.
    Resume,
    /// The folder holds this run, finished (`summary.json`).
    Finished,
}

fn refuse(out: &Path, reason: String) -> RunError {
    RunError::Folder {
        path: out.to_path_buf(),
        reason: format!("(--out) {reason}"),
    }
}

/// The entries of `dir` a run wrote: all but the lock of the run now starting
/// ([`LOCK_FILE`]).
pub(crate) fn run_entries(dir: &Path) -> Result<Vec<std::path::PathBuf>, IoError> {
    let mut paths = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(fs_err(dir))? {
        let path = entry.map_err(fs_err(dir))?.path();
        if path.file_name() != Some(std::ffi::OsStr::new(LOCK_FILE)) {
            paths.push(path);
        }
    }
    Ok(paths)
}

/// The run's marker, `run.json` ([`crate::run::RunMarker`]). A run starting writes it first and
/// `config.toml` second: `config.toml` is what makes a folder a run folder, and a folder that
/// has it has its marker too.
pub const MARKER_FILE: &str = "run.json";

/// Whether `dir` is absent or holds nothing but what a start stopped before its `config.toml`
/// leaves: a run lock, temporaries this program writes (`.NAME.tmp-PID`; removed when the run
/// starts, [`crate::io::clean_stale_temps`]) and the marker [`MARKER_FILE`].
pub fn is_empty(dir: &Path) -> Result<bool, IoError> {
    if !dir.exists() {
        return Ok(true);
    }
    Ok(run_entries(dir)?.iter().all(|p| {
        p.is_file()
            && p.file_name()
                .is_some_and(|n| n == MARKER_FILE || crate::io::is_temporary(&n.to_string_lossy()))
    }))
}

/// The first setting in which `a` and `b` differ, as `name`, value in `a`, value in `b`.
fn first_difference(
    a: &toml::Value,
    b: &toml::Value,
    prefix: &str,
) -> Option<(String, String, String)> {
    match (a, b) {
        (toml::Value::Table(ta), toml::Value::Table(tb)) => {
            // Plain values before sub-tables: `steps` is named before `cortex.train.steps`.
            let is_table = |k: &String| ta.get(k).or(tb.get(k)).is_some_and(|v| v.is_table());
            let keys: std::collections::BTreeSet<(bool, &String)> = ta
                .keys()
                .chain(tb.keys())
                .map(|k| (is_table(k), k))
                .collect();
            keys.into_iter().find_map(|(_, k)| {
                let name = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match (ta.get(k), tb.get(k)) {
                    (Some(x), Some(y)) => first_difference(x, y, &name),
                    (x, y) => Some((name, show(x), show(y))),
                }
            })
        }
        _ if a == b => None,
        _ => Some((prefix.to_string(), a.to_string(), b.to_string())),
    }
}

fn show(v: Option<&toml::Value>) -> String {
    v.map_or_else(|| "absent".to_string(), |v| v.to_string())
}

/// The config a run folder was started with (`config.toml`). Folders written before
/// `[cortex.train] steps` became the run's `steps` carry the cortex preset's own value there,
/// which no run used: it is read as `steps`.
pub fn read_config(out: &Path) -> Result<RunConfig, RunError> {
    let path = out.join("config.toml");
    let text = std::fs::read_to_string(&path).map_err(fs_err(&path))?;
    let mut config: RunConfig = toml::from_str(&text).map_err(|e| {
        RunError::from(science::config::ConfigError::Parse {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    })?;
    config.cortex.train.steps = config.steps;
    // Likewise `oracle_motion` was once written `true` beside an estimated motion; the
    // cortex followed `[cortex.m] mode`.
    config.oracle_motion = config.cortex.m.mode == cortex::config::MMode::Oracle;
    Ok(config)
}

/// Removes everything in the run folder `out` (which must hold a `config.toml`) but its lock.
fn empty_run_folder(out: &Path) -> Result<(), RunError> {
    if !out.join("config.toml").is_file() {
        return Err(refuse(
            out,
            "holds files but no config.toml, so it is not a colorvision run folder; --force \
             only replaces run folders: choose another --out"
                .into(),
        ));
    }
    for path in run_entries(out)? {
        let r = if path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        r.map_err(fs_err(&path))?;
    }
    Ok(())
}

/// Refuses an `out` that is a file.
pub fn refuse_file(out: &Path) -> Result<(), RunError> {
    if out.exists() && !out.is_dir() {
        return Err(refuse(
            out,
            "is a file, not a folder: choose another --out".into(),
        ));
    }
    Ok(())
}

/// Decides how the run of `config` starts in `out` (see [`Folder`]).
pub fn open(out: &Path, config: &RunConfig, folder: Folder) -> Result<Opened, RunError> {
    refuse_file(out)?;
    if is_empty(out)? {
        return Ok(Opened::Fresh);
    }
    if folder == Folder::Replace {
        empty_run_folder(out)?;
        return Ok(Opened::Fresh);
    }
    if !out.join("config.toml").is_file() {
        return Err(refuse(
            out,
            "holds files but no config.toml, so it is not a colorvision run folder: choose \
             another --out"
                .into(),
        ));
    }
    let theirs = read_config(out)?;
    if &theirs != config {
        let (a, b) = (
            toml::Value::try_from(&theirs).expect("a RunConfig serialises to TOML"),
            toml::Value::try_from(config).expect("a RunConfig serialises to TOML"),
        );
        let (field, there, here) = first_difference(&a, &b, "")
            .unwrap_or_else(|| ("(a float)".into(), "-".into(), "-".into()));
        return Err(refuse(
            out,
            format!(
                "holds another run (`{field}` is {there} there, {here} here): choose another \
                 --out, or --force to replace it"
            ),
        ));
    }
    let finished = out.join("summary.json").is_file();
    match folder {
        Folder::Resume if finished => Ok(Opened::Finished),
        _ if finished => Err(refuse(
            out,
            "already holds this run, finished (see its summary.json): --force runs it again".into(),
        )),
        Folder::Resume => Ok(Opened::Resume),
        _ => Err(refuse(
            out,
            "already holds this run, unfinished: add --resume to continue it from its last \
             checkpoint, or --force to start it again"
                .into(),
        )),
    }
}

/// [`read_config`], validated: a setting the code no longer accepts names the folder's
/// `config.toml`.
pub fn read_valid_config(dir: &Path) -> Result<RunConfig, RunError> {
    let config = read_config(dir)?;
    config.validate().map_err(|e| RunError::Folder {
        path: dir.join("config.toml"),
        reason: e.to_string(),
    })?;
    Ok(config)
}

/// The newest checkpoint of the run folder `dir` that verifies (newer ones that do not are
/// reported and skipped).
pub fn newest_valid_checkpoint(dir: &Path) -> Result<PathBuf, RunError> {
    let checkpoints = dir.join("checkpoints");
    let valid = match cortex::checkpoint::latest_valid(&checkpoints)? {
        Ok(v) => v,
        Err(failed) => {
            let why = failed
                .first()
                .map_or_else(|| "has no checkpoint".to_string(), |(_, e)| e.to_string());
            return Err(RunError::Folder {
                path: dir.to_path_buf(),
                reason: format!("no checkpoint of checkpoints/ loads: {why}"),
            });
        }
    };
    for (path, e) in &valid.skipped {
        println!(
            "colorvision: checkpoint {} does not load ({e}); using the one before",
            path.display()
        );
    }
    Ok(valid.path)
}

/// The checkpoint `--continue-from PATH` names: PATH itself when it is a checkpoint folder
/// (it holds `meta.json`), else the newest valid checkpoint of the run folder PATH. Checked
/// before any work: it verifies and its parameters load into the cortex `config` describes
/// (the same shapes), so a run that cannot start writes nothing.
pub fn checkpoint_to_continue(path: &Path, config: &RunConfig) -> Result<PathBuf, RunError> {
    let checkpoint = if path.join("meta.json").is_file() {
        path.to_path_buf()
    } else if path.join("checkpoints").is_dir() {
        newest_valid_checkpoint(path)?
    } else {
        return Err(RunError::Folder {
            path: path.to_path_buf(),
            reason: "--continue-from needs a checkpoint folder (with meta.json) or a run folder \
                     (with checkpoints/)"
                .into(),
        });
    };
    Trainer::continue_from(&checkpoint, Some(config.cortex.clone()))?;
    Ok(checkpoint)
}

/// Loads the config and last checkpoint of a run folder.
pub fn load_run(dir: &Path) -> Result<(RunConfig, Trainer, PathBuf), RunError> {
    let config = read_valid_config(dir)?;
    let checkpoint = newest_valid_checkpoint(dir)?;
    let trainer = Trainer::continue_from(&checkpoint, Some(config.cortex.clone()))?;
    Ok((config, trainer, checkpoint))
}

/// [`load_run`] at the checkpoint of `step` when given, else at the newest valid one.
pub fn load_run_step(
    dir: &Path,
    step: Option<u64>,
) -> Result<(RunConfig, Trainer, PathBuf), RunError> {
    match step {
        None => load_run(dir),
        Some(s) => load_run_at(dir, s),
    }
}

/// [`load_run`] at the checkpoint of `step` (`checkpoints/step_<step>/`), which must exist and
/// verify.
pub fn load_run_at(dir: &Path, step: u64) -> Result<(RunConfig, Trainer, PathBuf), RunError> {
    let config = read_valid_config(dir)?;
    let checkpoint = dir
        .join("checkpoints")
        .join(cortex::checkpoint::checkpoint_name(step));
    if !checkpoint.join("meta.json").is_file() {
        return Err(RunError::Folder {
            path: dir.to_path_buf(),
            reason: format!(
                "no checkpoint of step {step} ({} does not exist)",
                checkpoint.display()
            ),
        });
    }
    let trainer = Trainer::continue_from(&checkpoint, Some(config.cortex.clone()))?;
    Ok((config, trainer, checkpoint))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("cv_folder_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_folder_is_new_same_finished_or_refused() {
        let c = RunConfig::preset("tiny", "LMS").unwrap();
        let out = scratch("open");
        assert_eq!(open(&out, &c, Folder::New).unwrap(), Opened::Fresh);
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        for f in [Folder::New, Folder::Resume, Folder::Replace] {
            let e = open(&out, &c, f).unwrap_err().to_string();
            assert!(e.contains("not a colorvision run folder"), "{e}");
        }
        std::fs::remove_file(out.join("notes.txt")).unwrap();
        std::fs::write(out.join("config.toml"), c.to_toml()).unwrap();
        let e = open(&out, &c, Folder::New).unwrap_err().to_string();
        assert!(e.contains("--resume"), "{e}");
        assert_eq!(open(&out, &c, Folder::Resume).unwrap(), Opened::Resume);
        let mut other = c.clone();
        other.cones = "LM".into();
        let e = open(&out, &other, Folder::Resume).unwrap_err().to_string();
        assert!(e.contains("`cones` is \"LMS\" there, \"LM\" here"), "{e}");
        std::fs::write(out.join("summary.json"), "{}").unwrap();
        assert_eq!(open(&out, &c, Folder::Resume).unwrap(), Opened::Finished);
        let e = open(&out, &c, Folder::New).unwrap_err().to_string();
        assert!(e.contains("finished"), "{e}");
        assert_eq!(open(&out, &other, Folder::Replace).unwrap(), Opened::Fresh);
        assert!(is_empty(&out).unwrap());
        std::fs::remove_dir_all(out).ok();
    }
}
