//! The temporaries a stopped run leaves (`.NAME.tmp-PID`): a folder that holds nothing else was
//! never started — a run was killed at its first write — so a run starts in it as in an empty
//! one (see `folder::is_empty`) and `resume` says so; temporaries of writers no longer running
//! are removed when a run starts in, or resumes, its folder.

use crate::io::IoError;
use crate::run::error::RunError;
use crate::run::folder::is_empty;
use std::path::Path;

/// Whether `dir` exists and holds temporaries of this program alone (no run was started in
/// it: a run killed at its first write).
pub fn holds_only_temporaries(dir: &Path) -> Result<bool, IoError> {
    Ok(dir.is_dir() && !crate::run::folder::run_entries(dir)?.is_empty() && is_empty(dir)?)
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

/// The error of a folder that holds temporaries alone, removed first: no run was started in
/// it, so there is nothing to resume.
pub fn never_started(dir: &Path) -> RunError {
    if let Err(e) = remove_stale_temporaries(dir) {
        return e.into();
    }
    RunError::Folder {
        path: dir.to_path_buf(),
        reason: "was never started (a run stopped at its first write left only temporaries, \
                 now removed): start it again with the command that made it"
            .into(),
    }
}

/// For `--resume` on `out`: whether `out` was never started (it holds temporaries alone, now
/// removed, and the run starts there when `settings_given`); an error when there is nothing to
/// start it with.
pub fn resume_never_started(out: &Path, settings_given: bool) -> Result<bool, RunError> {
    if !holds_only_temporaries(out)? {
        return Ok(false);
    }
    if !settings_given {
        return Err(never_started(out));
    }
    remove_stale_temporaries(out)?;
    println!(
        "colorvision: {} was never started (it held only temporaries of a stopped start): \
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
        std::fs::remove_dir_all(out).ok();
    }
}
