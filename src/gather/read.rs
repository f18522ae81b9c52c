//! Reading one run folder ([`read_run`]): its status, steps, summary and settings, and what was
//! measured of it later — its colour-matching functions against Stiles & Burch, CMF-SIM over
//! its checkpoints and the figure of its averaged weights. A file that does not read is
//! reported on stderr by path and passed over; gather goes on.

use super::settings::run_settings;
use super::{stiles_burch, Run, Status};
use crate::averaging::Averaged;
use crate::convergence::{CheckpointCmf, VerdictOverCheckpoints};
use crate::sweep::task::{Failure, FAILED_FILE};
use science::summary::Summary;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Reads one run folder; a file that does not read is reported by path.
pub(super) fn read_run(dir: &Path, folder: String, rows: &BTreeMap<PathBuf, String>) -> Run {
    let summary_path = dir.join("summary.json");
    let mut summary = None;
    let status = if summary_path.is_file() {
        match Summary::read(&summary_path) {
            Ok(s) => {
                summary = Some(s);
                Status::Done
            }
            Err(e) => {
                eprintln!("colorvision gather: {}: {e}", summary_path.display());
                Status::Unreadable(e)
            }
        }
    } else if dir.join(crate::run::lock::LOCK_FILE).is_file() {
        let pid = std::fs::read_to_string(dir.join(crate::run::lock::LOCK_FILE))
            .ok()
            .and_then(|t| t.trim().parse().ok());
        Status::Running(pid)
    } else if dir.join(FAILED_FILE).is_file() {
        Status::Failed(read_failure(&dir.join(FAILED_FILE)))
    } else if newest_checkpoint(dir).is_some() {
        Status::Stopped
    } else {
        Status::Pending
    };
    let settings = match &summary {
        Some(s) => toml::Value::try_from(&s.config).map_err(|e| e.to_string()),
        None => read_toml(&dir.join("config.toml")),
    };
    let settings = settings.unwrap_or_else(|e| {
        if dir.join("config.toml").is_file() {
            eprintln!("colorvision gather: {}/config.toml: {e}", dir.display());
        }
        toml::Value::Table(Default::default())
    });
    let settings = run_settings(dir, &settings, rows);
    let steps = summary
        .as_ref()
        .map(|s| s.steps)
        .or_else(|| newest_checkpoint(dir));
    let stiles_burch = stiles_burch::read(dir).and_then(|r| {
        r.map_err(|e| {
            let path = dir.join(stiles_burch::TABLE_FILE);
            eprintln!("colorvision gather: {}: {e}", path.display());
        })
        .ok()
    });
    let over_checkpoints = over_checkpoints(dir, summary.as_ref());
    let other_location_seeds = other_location_seeds(dir, summary.as_ref());
    let averaged = averaged(dir);
    Run {
        folder,
        status,
        steps,
        summary,
        settings,
        stiles_burch,
        over_checkpoints,
        other_location_seeds,
        averaged,
    }
}

/// Where a run folder (and its record) keeps the CMF-SIM of the checkpoints `colorvision
/// convergence --cmf` measured.
pub const OVER_CHECKPOINTS_FILE: &str = "convergence/cmf_over_checkpoints.json";

/// CMF-SIM's verdict over the checkpoints measured in `dir` ([`OVER_CHECKPOINTS_FILE`], those
/// up to the run's steps) and the run's own final measurement; `None` without two such
/// measurements. A file that does not read is reported on stderr and passed over.
pub(super) fn over_checkpoints(
    dir: &Path,
    summary: Option<&Summary>,
) -> Option<VerdictOverCheckpoints> {
    let path = dir.join(OVER_CHECKPOINTS_FILE);
    let text = std::fs::read_to_string(&path).ok()?;
    let points: Vec<CheckpointCmf> = serde_json::from_str(&text)
        .map_err(|e| eprintln!("colorvision gather: {}: {e}", path.display()))
        .ok()?;
    VerdictOverCheckpoints::with_final(points, summary.and_then(CheckpointCmf::final_of))
}

/// The dimensions CMF-SIM measured on the run's final checkpoint with location seeds other than
/// the one its summary measured (`cmf-sim-step<N>-loc<L>/cmf_sim.json`, `N` the run's steps,
/// `L` not its `cmf_sim.seed` when the run measured itself), by location seed. A file that does not read is reported on stderr and
/// passed over.
pub(super) fn other_location_seeds(dir: &Path, summary: Option<&Summary>) -> Vec<(u64, usize)> {
    let Some(summary) = summary else {
        return Vec::new();
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let prefix = format!("cmf-sim-step{}-loc", summary.steps);
    // A run trained without measuring (`train`) has no figure of its own location seed.
    let measured = !summary.dimension_over_steps.is_empty();
    let mut found: Vec<(u64, usize)> = (entries.filter_map(|e| e.ok()))
        .filter_map(|entry| {
            let name = entry.file_name();
            let seed: u64 = name.to_string_lossy().strip_prefix(&prefix)?.parse().ok()?;
            let own = measured && seed == summary.config.cmf_sim.seed;
            let path = entry.path().join(colorimetry::cmf_sim_output::CMF_SIM_JSON);
            (!own).then(|| read_dimension(&path).map(|d| (seed, d)))?
        })
        .collect();
    found.sort_unstable();
    found
}

/// The integer field `dimension` of a `cmf_sim.json`; a file that does not read is reported.
fn read_dimension(path: &Path) -> Option<usize> {
    let read = crate::io::read_json::<serde_json::Value>(path).and_then(|v| {
        (v.get("dimension").and_then(|d| d.as_u64()))
            .map(|d| d as usize)
            .ok_or_else(|| "no integer field `dimension`".to_string())
    });
    read.map_err(|e| eprintln!("colorvision gather: {}: {e}", path.display()))
        .ok()
}

/// What `colorvision average` measured of `dir`'s checkpoints, when it wrote into `dir`
/// ([`crate::averaging::averaged_path`]); a file that does not read is reported on stderr and
/// passed over.
fn averaged(dir: &Path) -> Option<Averaged> {
    let path = crate::averaging::averaged_path(dir);
    if !path.is_file() {
        return None;
    }
    Averaged::read(&path)
        .map_err(|e| eprintln!("colorvision gather: {}: {e}", path.display()))
        .ok()
}

fn read_failure(path: &Path) -> String {
    match crate::io::read_json::<Failure>(path) {
        Ok(f) => format!("{} (exit {})", f.error, f.exit_code),
        Err(e) => format!("{} does not read: {e}", path.display()),
    }
}

fn read_toml(path: &Path) -> Result<toml::Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    toml::from_str(&text).map_err(|e| science::config::one_line(&e.to_string()))
}

/// The step of the newest `checkpoints/step_<k>` folder.
fn newest_checkpoint(dir: &Path) -> Option<u64> {
    std::fs::read_dir(dir.join("checkpoints"))
        .ok()?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            e.file_name()
                .to_string_lossy()
                .strip_prefix("step_")?
                .parse()
                .ok()
        })
        .max()
}
