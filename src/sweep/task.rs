//! One task of a sweep: `sweep.json` (the folder's list of runs) and `colorvision sweep
//! --task I DIR`, which runs task `I` the way `colorvision resume` does.
//!
//! Every run folder of a sweep is written with its `config.toml` and `run.json`, so a task is
//! a resume: a fresh folder starts from step 0, an interrupted one continues from its newest
//! checkpoint, a finished one (`summary.json`) is skipped. A task that fails for another
//! reason leaves `failed.json` ([`Failure`]) in its run folder, which `colorvision gather`
//! reports; a later success removes it. A stop by SIGINT/SIGTERM is not a failure (the run
//! checkpointed; exit code 130).

use crate::cli::ResumeOptions;
use crate::run::error::RunError;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Name of the sweep folder's list of runs.
pub const MANIFEST_FILE: &str = "sweep.json";
/// Name of the file a failed task leaves in its run folder.
pub const FAILED_FILE: &str = "failed.json";

/// `sweep.json`: the runs of a sweep folder in array-task order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The spec it was expanded from.
    pub spec: PathBuf,
    /// `run` or `train`.
    pub command: String,
    /// The grid's keys, in order.
    pub keys: Vec<String>,
    /// What each array task asks Slurm for.
    pub resources: super::script::Resources,
    /// One entry per run; entry `i` is array task `i`.
    pub tasks: Vec<TaskEntry>,
}

/// One run of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaskEntry {
    /// Its folder, inside the sweep folder.
    pub folder: String,
    /// Its grid values, as TOML text (`"LMS"`, `3`, `0.001`).
    pub settings: BTreeMap<String, String>,
}

/// `failed.json`: why a task stopped without a result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// The error, one line, as the command printed it.
    pub error: String,
    /// The exit code the task ended with.
    pub exit_code: i32,
}

impl Manifest {
    /// Reads `DIR/sweep.json`.
    pub fn read(dir: &Path) -> Result<Manifest, RunError> {
        let path = dir.join(MANIFEST_FILE);
        if !path.is_file() {
            return Err(RunError::Folder {
                path: dir.to_path_buf(),
                reason: format!(
                    "is not a sweep folder (no {MANIFEST_FILE}; `colorvision sweep SPEC.toml \
                     --out DIR` writes one)"
                ),
            });
        }
        let text = std::fs::read_to_string(&path).map_err(crate::io::fs_err(&path))?;
        serde_json::from_str(&text).map_err(|e| RunError::Folder {
            path,
            reason: format!("invalid sweep list: {e}"),
        })
    }
}

/// `colorvision sweep --task INDEX DIR`: runs (or continues, or skips) task `index`.
pub fn run_task(dir: &Path, index: usize) -> Result<(), RunError> {
    let manifest = Manifest::read(dir)?;
    let n = manifest.tasks.len();
    let Some(entry) = manifest.tasks.get(index) else {
        return Err(RunError::Folder {
            path: dir.to_path_buf(),
            reason: format!(
                "(--task) has tasks 0 to {}, not {index}",
                n.saturating_sub(1)
            ),
        });
    };
    let run_dir = dir.join(&entry.folder);
    let settings: Vec<String> = entry
        .settings
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    println!(
        "colorvision sweep: task {index} of 0..{n}: {} ({})",
        run_dir.display(),
        settings.join(", ")
    );
    let failed = run_dir.join(FAILED_FILE);
    match crate::commands::resume(&ResumeOptions {
        dir: run_dir.clone(),
        steps: None,
    }) {
        Ok(()) => {
            if failed.exists() {
                std::fs::remove_file(&failed).map_err(crate::io::fs_err(&failed))?;
            }
            Ok(())
        }
        Err(e @ RunError::Interrupted { .. }) => Err(e),
        Err(e) => {
            let failure = Failure {
                error: e.to_string(),
                exit_code: e.exit_code(),
            };
            if let Err(w) = crate::io::write_json(&failed, &failure) {
                eprintln!("colorvision: cannot record the failure: {w}");
            }
            Err(e)
        }
    }
}
