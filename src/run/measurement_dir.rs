//! Where a measurement of a finished run (`cmf-sim --run DIR`, `scope --run DIR`) writes: the
//! folder `--out` names, or a sub-folder of its own inside the run folder (`DIR/cmf-sim/`,
//! `DIR/scope/`). Never the run's own record: the run folder itself, another run folder, or
//! what the run writes inside its folder ([`RUN_RECORD`]) is refused.

use crate::run::error::RunError;
use std::path::{Component, Path, PathBuf};

/// Entries of a run folder that the run itself writes (its record); a measurement of the run
/// writes none of them.
pub const RUN_RECORD: &[&str] = &[
    "config.toml",
    "run.json",
    "summary.json",
    "metrics.csv",
    "cmf_sim.json",
    "cmf_sim_errors.svg",
    "loss.svg",
    "alignment.svg",
    "dimension.svg",
    "checkpoints",
    "pictures",
    "cmf_sim",
];

/// `path` made absolute, `.` and `..` removed lexically, then symbolic links resolved as far
/// as it exists (the part that does not exist yet is appended as written).
fn resolved(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut lexical = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                lexical.pop();
            }
            other => lexical.push(other),
        }
    }
    let mut existing = lexical.as_path();
    let mut rest = Vec::new();
    while let (Err(_), Some(parent), Some(name)) = (
        existing.canonicalize(),
        existing.parent(),
        existing.file_name(),
    ) {
        rest.push(name.to_os_string());
        existing = parent;
    }
    let base = existing
        .canonicalize()
        .unwrap_or_else(|_| existing.to_path_buf());
    rest.iter().rev().fold(base, |p, n| p.join(n))
}

/// The folder a measurement of the run folder `run` writes into: `out` when given (the
/// `--out` option), else `run/<own>`. Refuses the run folder itself, a folder holding another
/// run (`config.toml`), and anything of the run's record ([`RUN_RECORD`]).
pub fn measurement_dir(run: &Path, out: Option<&PathBuf>, own: &str) -> Result<PathBuf, RunError> {
    let Some(out) = out else {
        return Ok(run.join(own));
    };
    let refuse = |reason: &str| RunError::Folder {
        path: out.clone(),
        reason: format!("(--out) {reason}: choose a folder of its own"),
    };
    let (run_abs, out_abs) = (resolved(run), resolved(out));
    if out_abs == run_abs {
        return Err(refuse(
            "is the run folder of --run, whose record a measurement never overwrites",
        ));
    }
    if let Ok(inside) = out_abs.strip_prefix(&run_abs) {
        let first = inside
            .components()
            .next()
            .map(|c| c.as_os_str().to_string_lossy());
        if first.is_some_and(|f| RUN_RECORD.contains(&f.as_ref())) {
            return Err(refuse("is part of the record of the run folder of --run"));
        }
    }
    if out.join("config.toml").is_file() {
        return Err(refuse(
            "holds a run (config.toml), whose record a measurement never overwrites",
        ));
    }
    Ok(out.clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_measurement_never_writes_into_the_record_of_a_run() {
        let run = std::env::temp_dir().join(format!("cv_measure_{}", std::process::id()));
        std::fs::create_dir_all(run.join("pictures")).unwrap();
        std::fs::write(run.join("config.toml"), "").unwrap();
        assert_eq!(
            measurement_dir(&run, None, "scope").unwrap(),
            run.join("scope")
        );
        let mine = run.join("elsewhere");
        assert_eq!(measurement_dir(&run, Some(&mine), "scope").unwrap(), mine);
        for bad in [
            run.clone(),
            run.join("."),
            run.join("pictures"),
            run.join("pictures").join("new"),
            run.join("scope").join("..").join("checkpoints"),
        ] {
            let e = measurement_dir(&run, Some(&bad), "scope")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("(--out)") && e.contains("run"),
                "{}: {e}",
                bad.display()
            );
        }
        std::fs::remove_dir_all(run).ok();
    }
}
