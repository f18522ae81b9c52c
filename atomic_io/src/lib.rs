//! atomic_io — the one way the workspace writes a file.
//!
//! The bytes land in a hidden temporary sibling `.NAME.tmp-PID` (same folder, so the rename
//! cannot cross file systems), which is synced and renamed over the target; then the folder is
//! synced. A process killed at any point leaves either the old file or the new one under the
//! real name, never a half-written one; the temporaries it leaves carry its process id
//! ([`TEMP_MARK`]) so that a later run can tell them from a live writer's ([`process_alive`])
//! and remove them.
//!
//! A leaf crate with no dependency on the others, so that every crate of the workspace
//! (`autodiff`, `colorimetry`, the root package) writes through the same code.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file-system failure, naming the file or folder it concerns.
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct FileError {
    /// The file or folder.
    pub path: PathBuf,
    /// What the file system said.
    #[source]
    pub source: std::io::Error,
}

/// Wraps an `std::io::Error` with the path it concerns.
pub fn file_err(path: &Path) -> impl FnOnce(std::io::Error) -> FileError + '_ {
    move |source| FileError {
        path: path.to_path_buf(),
        source,
    }
}

/// Marks a temporary file or folder: `.NAME.tmp-PID`.
pub const TEMP_MARK: &str = ".tmp-";

/// The temporary sibling `path` is written through: `.NAME.tmp-PID` in the same folder.
pub fn temp_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = path.parent().unwrap_or(Path::new(""));
    dir.join(format!(".{name}{TEMP_MARK}{}", std::process::id()))
}

/// Whether the process with this id is running, i.e. whether a temporary or lock it left is
/// still its own (Linux: `/proc/PID` exists; elsewhere only this process counts as running).
pub fn process_alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// Flushes a folder's entries (a rename into it) to disk. Only Unix can open a folder for
/// syncing; elsewhere the rename's own ordering is what there is.
pub fn sync_dir(dir: &Path) -> Result<(), FileError> {
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    if cfg!(unix) {
        fs::File::open(dir)
            .and_then(|f| f.sync_all())
            .map_err(file_err(dir))?;
    }
    Ok(())
}

/// A function told of each file-system step this crate (and writers that publish files
/// themselves) takes: `"write"` once a temporary holds its bytes, before the rename, and
/// `"rename"` once a file is in place under its real name. Fault-injection tests kill the
/// process at the Nth step; unset, nothing is called.
pub type FaultHook = fn(&'static str);

static FAULT_HOOK: std::sync::OnceLock<FaultHook> = std::sync::OnceLock::new();

/// Sets the [`FaultHook`] for the rest of the process (the first call wins).
pub fn set_fault_hook(hook: FaultHook) {
    let _ = FAULT_HOOK.set(hook);
}

/// Tells the [`FaultHook`], if one is set, of the step `stage` (`"write"` or `"rename"`).
pub fn fault_point(stage: &'static str) {
    if let Some(hook) = FAULT_HOOK.get() {
        hook(stage);
    }
}

static IN_FLIGHT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
static CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

thread_local! {
    static DEPTH: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Held while a writer has temporaries on disk ([`write_via`], and writers that publish files
/// themselves: a checkpoint folder, a staging folder, a lock): [`close_writes`] waits for every
/// guard to drop, and once it was called a new outermost guard never returns, so a process
/// leaving on its own (a stop whose stage did not end in time) leaves no temporary behind.
/// Guards nest within a thread.
#[must_use = "the guard covers the writes until it is dropped"]
pub struct WriteGuard(());

impl WriteGuard {
    /// Enters a write; blocks forever once [`close_writes`] was called (the process is
    /// leaving), unless this thread is inside a write already.
    pub fn enter() -> WriteGuard {
        use std::sync::atomic::Ordering::SeqCst;
        let depth = DEPTH.with(|d| d.get());
        IN_FLIGHT.fetch_add(1, SeqCst);
        if depth == 0 && CLOSED.load(SeqCst) {
            IN_FLIGHT.fetch_sub(1, SeqCst);
            loop {
                std::thread::park();
            }
        }
        DEPTH.with(|d| d.set(depth + 1));
        WriteGuard(())
    }
}

impl Drop for WriteGuard {
    fn drop(&mut self) {
        DEPTH.with(|d| d.set(d.get() - 1));
        IN_FLIGHT.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
    }
}

/// Lets no new write start ([`WriteGuard::enter`] blocks) and waits, up to `limit`, for the
/// writes under way to end; returns whether they did.
pub fn close_writes(limit: std::time::Duration) -> bool {
    use std::sync::atomic::Ordering::SeqCst;
    CLOSED.store(true, SeqCst);
    let start = std::time::Instant::now();
    while IN_FLIGHT.load(SeqCst) > 0 {
        if start.elapsed() > limit {
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    true
}

/// `write` fills a temporary sibling of `path` (whose parent folders are created first), which
/// is synced and renamed over `path`; the folder is synced. On an error the temporary is
/// removed and `path` is untouched.
pub fn write_via<E: From<FileError>>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let dir = path.parent().unwrap_or(Path::new(""));
    if !dir.as_os_str().is_empty() {
        fs::create_dir_all(dir).map_err(file_err(dir))?;
    }
    let _guard = WriteGuard::enter();
    let tmp = temp_sibling(path);
    let result = write(&tmp).and_then(|()| {
        fs::File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(file_err(&tmp))?;
        fault_point("write");
        fs::rename(&tmp, path).map_err(file_err(path))?;
        fault_point("rename");
        Ok(sync_dir(dir)?)
    });
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Writes `bytes` to `path` atomically (see [`write_via`]), creating parent folders.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    write_via(path, |tmp| {
        let mut f = fs::File::create(tmp).map_err(file_err(tmp))?;
        f.write_all(bytes).map_err(file_err(tmp))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("atomic_io_{name}_{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary() {
        let dir = scratch("replace");
        let path = dir.join("sub").join("x.json");
        write_atomic(&path, b"old").unwrap();
        write_atomic(&path, b"new").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        let names: Vec<_> = fs::read_dir(dir.join("sub"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("x.json")]);
        fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_the_temporary() {
        let dir = scratch("fail");
        let path = dir.join("x.json");
        write_atomic(&path, b"old").unwrap();
        let r: Result<(), FileError> = write_via(&path, |tmp| {
            fs::write(tmp, b"half").unwrap();
            Err(file_err(tmp)(std::io::Error::other("disk full")))
        });
        let e = r.unwrap_err().to_string();
        assert!(e.contains(".x.json.tmp-") && e.contains("disk full"), "{e}");
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert!(!temp_sibling(&path).exists());
        fs::remove_dir_all(dir).ok();
    }
}
