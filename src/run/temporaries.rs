//! What a stopped start leaves: temporaries (`.NAME.tmp-PID`) and perhaps the run's marker
//! (`run.json`, written before `config.toml`). A folder that holds nothing else was never
//! started — the run was killed before its `config.toml` was in place — so a run starts in it
//! as in an empty one (see `folder::is_empty`) and `resume` says so; temporaries of writers no
//! longer running are removed when a run starts in, or resumes, its folder.

use crate::io::IoError;
use crate::run::error::RunError;
use crate::run::folder::is_empty;
use std::path::Path;

/// Whether `dir` exists and holds what a stopped start leaves, and nothing else (no run was
/// started in it: a run killed before its `config.toml` was written).
/// A lock whose process is gone counts as left; a live one does not (its run is starting).
pub fn holds_only_temporaries(dir: &Path) -> Result<bool, IoError> {
    if !dir.is_dir() || crate::run::lock::live_holder(dir).is_some() {
        return Ok(false);
    }
    let holds_something = std::fs::read_dir(dir)
        .map_err(crate::io::fs_err(dir))?
        .next()
        .is_some();
    Ok(holds_something && is_empty(dir)?)
}

/// Removes the temporaries of stopped writers from `dir` (recursively), saying so.
pub fn remove_stale_temporaries(dir: &Path) -> Result<(), IoError> {
    for p in crate::io::clean_stale_temps(dir)? {
        println!(
            "  removed a temporary left by a stopped run: {}",
            p.display()
        );
    }
    Ok(())
}

/// The error of a folder a start stopped in before its `config.toml`, its temporaries removed
/// first: no run was started in it, so there is nothing to resume.
pub fn never_started(dir: &Path) -> RunError {
    if let Err(e) = remove_stale_temporaries(dir) {
        return e.into();
    }
    RunError::Folder {
        path: dir.to_path_buf(),
        reason: "was never started (a run stopped before writing its config.toml left only \
                 temporaries, now removed, and perhaps run.json): start it again with the \
                 command that made it"
            .into(),
    }
}

/// For `--resume` on `out`: whether `out` was never started (it holds what a stopped start
/// leaves, its temporaries now removed, and the run starts there when `settings_given`); an
/// error when there is nothing to start it with.
pub fn resume_never_started(out: &Path, settings_given: bool) -> Result<bool, RunError> {
    if !holds_only_temporaries(out)? {
        return Ok(false);
    }
    if !settings_given {
        return Err(never_started(out));
    }
    remove_stale_temporaries(out)?;
    println!(
        "colorvision: {} was never started (it held only what a stopped start leaves): \
         starting the run",
        out.display()
    );
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::folder::{open, Folder, Opened};
    use science::config::RunConfig;

    fn scratch(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("cv_temporaries_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_folder_of_temporaries_alone_is_empty_and_never_started() {
        let c = RunConfig::preset("tiny", "LMS").unwrap();
        let out = scratch("temporaries");
        std::fs::create_dir_all(&out).unwrap();
        // What a run killed inside the lock's first write leaves: a 0-byte temporary.
        let left = out.join("..lock.tmp-4294967295.tmp-4294967295");
        std::fs::write(&left, "").unwrap();
        assert!(holds_only_temporaries(&out).unwrap());
        assert_eq!(open(&out, &c, Folder::New).unwrap(), Opened::Fresh);
        let e = never_started(&out).to_string();
        assert!(e.contains("never started"), "{e}");
        assert!(!left.exists(), "the stale temporary is removed");
        assert!(!holds_only_temporaries(&out).unwrap(), "an empty folder");
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        std::fs::write(&left, "").unwrap();
        assert!(!holds_only_temporaries(&out).unwrap());
        assert!(open(&out, &c, Folder::New).is_err());
        std::fs::remove_file(out.join("notes.txt")).unwrap();
        // A start stopped after its marker and before its config.toml, its lock left behind
        // by the dead process (4294967295 never runs).
        std::fs::write(out.join("run.json"), "{}").unwrap();
        std::fs::write(out.join(".lock"), "4294967295\n").unwrap();
        assert!(holds_only_temporaries(&out).unwrap());
        assert_eq!(open(&out, &c, Folder::New).unwrap(), Opened::Fresh);
        // The lock alone, too; a live one is a run starting, not a stopped start.
        std::fs::remove_file(out.join("run.json")).unwrap();
        assert!(holds_only_temporaries(&out).unwrap());
        std::fs::write(out.join(".lock"), format!("{}\n", std::process::id())).unwrap();
        assert!(!holds_only_temporaries(&out).unwrap());
        std::fs::remove_file(out.join(".lock")).unwrap();
        std::fs::write(out.join("run.json"), "{}").unwrap();
        std::fs::write(out.join("config.toml"), c.to_toml()).unwrap();
        assert!(!holds_only_temporaries(&out).unwrap(), "a run folder");
        std::fs::remove_dir_all(out).ok();
    }
}
