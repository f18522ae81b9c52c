//! The checkpoints of a folder: their names, newest first (an interrupted re-save counted as
//! its step), the newest that verifies, and the recovery of a re-save that a killed process
//! left half done.

use super::*;

/// The step of a checkpoint folder name: `step_K`, or `.step_K.old-PID` (a checkpoint moved
/// aside while its step was re-saved), with whether it is the aside copy.
fn parse_name(name: &str) -> Option<(u64, bool)> {
    if let Some(num) = name.strip_prefix("step_") {
        return num.parse().ok().map(|s| (s, false));
    }
    let rest = name.strip_prefix(".step_")?;
    let (num, _) = rest.split_once(".old-")?;
    num.parse().ok().map(|s| (s, true))
}

/// Every complete-looking checkpoint under `dir` (a `meta.json` present), newest first. A
/// folder moved aside by an interrupted re-save counts when its step has no other folder.
pub fn newest_first(dir: &Path) -> Result<Vec<PathBuf>, CortexError> {
    if !dir.exists() {
        return Ok(Vec::new());
    }
    let mut found: BTreeMap<(u64, bool), PathBuf> = BTreeMap::new();
    for entry in std::fs::read_dir(dir).map_err(io(dir))? {
        let entry = entry.map_err(io(dir))?;
        let name = entry.file_name().to_string_lossy().to_string();
        let Some((step, aside)) = parse_name(&name) else {
            continue;
        };
        if entry.path().join("meta.json").exists() {
            found.insert((step, aside), entry.path());
        }
    }
    let mut out = Vec::new();
    let mut last_step = None;
    for ((step, _), path) in found.into_iter().rev() {
        // Per step the real folder sorts after (and so before, reversed) the aside copy.
        if last_step != Some(step) {
            out.push(path);
            last_step = Some(step);
        }
    }
    Ok(out)
}

/// The checkpoint of the highest step under `dir` (complete ones only), if any. Does not
/// verify it; see [`latest_valid`].
pub fn latest_checkpoint(dir: &Path) -> Result<Option<PathBuf>, CortexError> {
    Ok(newest_first(dir)?.into_iter().next())
}

/// The newest checkpoint under `dir` that passes [`verify_params`] (what a reading or a
/// continued run loads), its metadata, and every newer one that failed with the reason.
pub struct Valid {
    /// The checkpoint folder.
    pub path: PathBuf,
    /// Its verified metadata.
    pub meta: CheckpointMeta,
    /// Newer checkpoints that failed to verify, newest first, with the error.
    pub skipped: Vec<(PathBuf, CortexError)>,
}

/// The newest checkpoint under `dir` that verifies (see [`Valid`]); `None` when there is none,
/// with the failures of those that did not.
pub fn latest_valid(dir: &Path) -> Result<Result<Valid, Vec<(PathBuf, CortexError)>>, CortexError> {
    let mut skipped = Vec::new();
    for path in newest_first(dir)? {
        match verify_params(&path) {
            Ok(meta) => {
                return Ok(Ok(Valid {
                    path,
                    meta,
                    skipped,
                }))
            }
            Err(e) => skipped.push((path, e)),
        }
    }
    Ok(Err(skipped))
}

fn process_alive(pid: &str) -> bool {
    pid.parse::<u32>().is_ok_and(atomic_io::process_alive)
}

/// Tidies `dir` after a killed writer: a checkpoint moved aside by an interrupted re-save is
/// moved back when its step has no folder (else removed), and temporary folders of processes
/// no longer running are removed. Returns what it did, one line each.
pub fn recover(dir: &Path) -> Result<Vec<String>, CortexError> {
    let mut done = Vec::new();
    if !dir.is_dir() {
        return Ok(done);
    }
    for entry in std::fs::read_dir(dir).map_err(io(dir))? {
        let path = entry.map_err(io(dir))?.path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Some(rest) = name.strip_prefix(".step_") else {
            continue;
        };
        if let Some((num, pid)) = rest.split_once(".old-") {
            if process_alive(pid) {
                continue;
            }
            let fin = dir.join(format!("step_{num}"));
            if fin.exists() {
                std::fs::remove_dir_all(&path).map_err(io(&path))?;
                done.push(format!("removed {}", path.display()));
            } else {
                std::fs::rename(&path, &fin).map_err(io(&path))?;
                done.push(format!("restored {}", fin.display()));
            }
        } else if let Some((_, pid)) = rest.split_once(atomic_io::TEMP_MARK) {
            if !process_alive(pid) {
                std::fs::remove_dir_all(&path).map_err(io(&path))?;
                done.push(format!("removed {}", path.display()));
            }
        }
    }
    Ok(done)
}
