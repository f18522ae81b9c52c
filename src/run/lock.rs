//! One process at a time trains into a run folder: `DIR/.lock` holds the id of the process
//! that does (decimal, one line), for as long as it runs.
//!
//! - Taking the lock is one atomic step: the id is written to a temporary sibling
//!   (`.lock.tmp-PID`), which is hard-linked to `.lock`; the link fails if `.lock` exists, so
//!   a `.lock` is never seen empty or half-written.
//! - A `.lock` whose process is running (Linux: `/proc/PID` exists; the caller's own id
//!   counts) refuses the run with a one-line error naming the folder and the process.
//! - A `.lock` whose process is gone (killed), or written before the machine last booted
//!   (its id may since belong to another process), is taken over, and the run says so: it is
//!   first renamed aside, so that of two processes taking over the same stale lock only one
//!   removes it.
//! - [`RunLock`] removes `.lock` when dropped, on success, error and interrupt alike; a folder
//!   it created for the lock alone is removed too, so a refused run leaves nothing behind.

use crate::io::{fs_err, IoError};
use crate::run::error::RunError;
use atomic_io::process_alive;
use std::path::{Path, PathBuf};

/// Name of the lock file in a run folder.
pub const LOCK_FILE: &str = ".lock";

/// The lock of one run folder, held until dropped.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
    /// The folder did not exist before the lock was taken.
    created_dir: bool,
    /// The lock was taken (a guard dropped on the way to a refusal holds none).
    taken: bool,
}

/// The locks this process holds, for [`release_held`]: path and whether its folder was made
/// for it.
static HELD: std::sync::Mutex<Vec<(PathBuf, bool)>> = std::sync::Mutex::new(Vec::new());

fn held() -> std::sync::MutexGuard<'static, Vec<(PathBuf, bool)>> {
    HELD.lock().unwrap_or_else(|e| e.into_inner())
}

/// Releases every lock this process holds, as dropping them would: for a process that leaves
/// without unwinding (a stop whose stage did not end in time, `crate::interrupt`).
pub fn release_held() {
    for (path, created_dir) in held().drain(..) {
        release(&path, created_dir);
    }
}

/// Removes the lock at `path` if this process holds it, and its folder if it was made for it
/// and is empty.
fn release(path: &Path, created_dir: bool) {
    if holder(path) == Some(std::process::id()) {
        let _ = std::fs::remove_file(path);
    }
    if created_dir {
        if let Some(dir) = path.parent() {
            let _ = std::fs::remove_dir(dir);
        }
    }
}

/// The process id a lock file names, if it names one.
fn holder(path: &Path) -> Option<u32> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// Seconds since the Unix epoch at which the machine booted (Linux: `btime` of `/proc/stat`).
fn boot_time() -> Option<u64> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    stat.lines()
        .find_map(|l| l.strip_prefix("btime "))
        .and_then(|t| t.trim().parse().ok())
}

/// Whether the lock file was written before the machine last booted.
fn before_boot(path: &Path) -> bool {
    let written = std::fs::metadata(path)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok());
    matches!((written, boot_time()), (Some(w), Some(b)) if w.as_secs() < b)
}

/// The running process that holds the lock of `dir`, if one does (a stale lock names none).
pub fn live_holder(dir: &Path) -> Option<u32> {
    let path = dir.join(LOCK_FILE);
    holder(&path).filter(|&p| process_alive(p) && !before_boot(&path))
}

/// Links a file holding this process's id to `lock`; `Ok(false)` when `lock` exists.
fn try_create(lock: &Path) -> Result<bool, IoError> {
    let _guard = atomic_io::WriteGuard::enter();
    let tmp = atomic_io::temp_sibling(lock);
    atomic_io::write_atomic(&tmp, format!("{}\n", std::process::id()).as_bytes())?;
    crate::interrupt::fault_point("lock-written", 0);
    let linked = std::fs::hard_link(&tmp, lock);
    if linked.is_ok() {
        atomic_io::fault_point("rename");
    }
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(false),
        Err(e) => Err(fs_err(lock)(e)),
    }
}

/// Removes the stale lock of the dead process `dead`, unless another process replaced it
/// meanwhile (then it is put back).
fn remove_stale(lock: &Path, dead: Option<u32>) -> Result<(), IoError> {
    let _guard = atomic_io::WriteGuard::enter();
    let aside = lock.with_file_name(format!("{LOCK_FILE}.stale-{}", std::process::id()));
    match std::fs::rename(lock, &aside) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(fs_err(lock)(e)),
    }
    if holder(&aside) == dead {
        std::fs::remove_file(&aside).map_err(fs_err(&aside))
    } else {
        std::fs::rename(&aside, lock).map_err(fs_err(lock))
    }
}

/// The folder `dir` refused a write: what could not be done and the system's reason (a
/// read-only folder or file system, a missing permission).
fn unwritable(dir: &Path, what: &str, e: std::io::Error) -> RunError {
    RunError::Folder {
        path: dir.to_path_buf(),
        reason: format!("{what}: {e}"),
    }
}

impl RunLock {
    /// Takes the lock of the run folder `dir` (created if missing), or refuses when a running
    /// process holds it.
    pub fn acquire(dir: &Path) -> Result<RunLock, RunError> {
        let created_dir = !dir.exists();
        std::fs::create_dir_all(dir).map_err(|e| unwritable(dir, "cannot be made", e))?;
        let path = dir.join(LOCK_FILE);
        let mut guard = RunLock {
            path,
            created_dir,
            taken: false,
        };
        for _ in 0..3 {
            let taken = try_create(&guard.path).map_err(|e| match e {
                IoError::Fs { source, .. } => unwritable(
                    dir,
                    &format!("cannot be written (its lock {LOCK_FILE})"),
                    source,
                ),
                other => other.into(),
            })?;
            if taken {
                guard.taken = true;
                held().push((guard.path.clone(), guard.created_dir));
                return Ok(guard);
            }
            let pid = holder(&guard.path);
            let stale = before_boot(&guard.path);
            if let Some(pid) = pid.filter(|&p| process_alive(p) && !stale) {
                guard.created_dir = false;
                return Err(RunError::Folder {
                    path: dir.to_path_buf(),
                    reason: format!(
                        "is in use by process {pid}, which is training into it ({LOCK_FILE}): \
                         wait for it to finish or stop it"
                    ),
                });
            }
            remove_stale(&guard.path, pid)?;
            println!(
                "  took over the lock of {} from process {}, which {}",
                dir.display(),
                pid.map_or_else(|| "(unreadable)".to_string(), |p| p.to_string()),
                if stale {
                    "wrote it before the machine last booted"
                } else {
                    "is no longer running"
                }
            );
        }
        guard.created_dir = false;
        Err(RunError::Folder {
            path: dir.to_path_buf(),
            reason: format!("its {LOCK_FILE} keeps changing: another process is starting a run"),
        })
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        if self.taken {
            held().retain(|(p, _)| p != &self.path);
            release(&self.path, self.created_dir);
        } else if self.created_dir {
            if let Some(dir) = self.path.parent() {
                let _ = std::fs::remove_dir(dir);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("cv_lock_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_live_lock_refuses_a_stale_one_is_taken_over_and_drop_releases() {
        let dir = scratch("unit");
        let lock = RunLock::acquire(&dir).unwrap();
        assert_eq!(holder(&dir.join(LOCK_FILE)), Some(std::process::id()));
        let e = RunLock::acquire(&dir).unwrap_err().to_string();
        assert!(
            e.contains(&format!("process {}", std::process::id())),
            "{e}"
        );
        drop(lock);
        assert!(
            !dir.exists(),
            "the folder made for the lock alone is removed"
        );
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(LOCK_FILE), "4000000\n").unwrap();
        let lock = RunLock::acquire(&dir).unwrap();
        assert_eq!(holder(&dir.join(LOCK_FILE)), Some(std::process::id()));
        drop(lock);
        if boot_time().is_some() {
            // A live id in a lock written before the last boot names another process now.
            let path = dir.join(LOCK_FILE);
            std::fs::write(&path, format!("{}\n", std::process::id())).unwrap();
            let long_ago = std::time::UNIX_EPOCH + std::time::Duration::from_secs(1000);
            let f = std::fs::File::options().write(true).open(&path).unwrap();
            f.set_modified(long_ago).unwrap();
            drop(f);
            drop(RunLock::acquire(&dir).unwrap());
        }
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "{left:?}");
        std::fs::remove_dir_all(dir).ok();
    }
}
