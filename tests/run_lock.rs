//! A run folder is trained into by one process at a time: a `.lock` naming a running process
//! refuses the run with a one-line error naming the folder and the process and leaves the
//! folder as it was; a `.lock` naming a process that no longer runs is taken over; the lock is
//! gone when the run ends, finished or stopped.

mod common;

use common::text;
use std::path::Path;
use std::process::{Command, Output};

use common::BIN;

/// Above Linux's largest possible process id (`PID_MAX_LIMIT` = 2²²), so never running.
const DEAD_PID: u32 = 4_194_305;

fn train(dir: &Path, fault: Option<&str>) -> Output {
    let args = ["train", "--preset", "tiny", "--steps", "2", "--out", "out"];
    common::command(dir, &args, fault)
        .output()
        .expect("the binary runs")
}

#[test]
fn a_live_lock_is_refused_and_a_stale_one_taken_over() {
    let dir = std::env::temp_dir().join(format!("cv_run_lock_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (out, lock) = (dir.join("out"), dir.join("out").join(".lock"));
    std::fs::create_dir_all(&out).unwrap();

    let me = std::process::id();
    std::fs::write(&lock, format!("{me}\n")).unwrap();
    let o = train(&dir, None);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("out: is in use by process") && err.contains(&me.to_string()),
        "{err}"
    );
    let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
    assert_eq!(
        left.len(),
        1,
        "the refused run wrote into the folder: {left:?}"
    );
    assert_eq!(std::fs::read_to_string(&lock).unwrap(), format!("{me}\n"));

    std::fs::write(&lock, format!("{DEAD_PID}\n")).unwrap();
    let o = train(&dir, Some("interrupt@step:1"));
    assert_eq!(o.status.code(), Some(130), "{}", text(&o));
    assert!(
        text(&o).contains(&format!(
            "took over the lock of out from process {DEAD_PID}"
        )),
        "{}",
        text(&o)
    );
    assert!(!lock.exists(), "a stopped run leaves its lock behind");

    let o = Command::new(BIN)
        .args(["resume", "out"])
        .current_dir(&dir)
        .env_remove("COLORVISION_FAULT")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("took over"), "{}", text(&o));
    assert!(!lock.exists(), "a finished run leaves its lock behind");
    std::fs::remove_dir_all(dir).ok();
}

/// Unmounts its folder when dropped.
struct Unmount(std::path::PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// `train` into `out` under `dir`: refused in one line naming the folder and `what`.
fn refused_naming(dir: &Path, out: &str, what: &str) {
    let args = ["train", "--preset", "tiny", "--steps", "2", "--out", out];
    let o = common::command(dir, &args, None).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains(out) && err.contains(what), "{err}");
}

#[test]
fn a_folder_that_cannot_be_made_or_written_is_named_with_the_reason() {
    let dir = std::env::temp_dir().join(format!("cv_run_unwritable_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // A folder under a file cannot be made.
    std::fs::write(dir.join("a-file"), b"").unwrap();
    refused_naming(&dir, "a-file/out", "cannot be made: Not a directory");
    // A read-only folder cannot be written: by its permissions for a user, by a read-only
    // mount for root (where the mount can be made; permissions do not bind root).
    let ro = dir.join("read-only");
    std::fs::create_dir_all(&ro).unwrap();
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    let made = if root {
        Command::new("mount")
            .args(["-t", "tmpfs", "-o", "ro,size=1m", "tmpfs"])
            .arg(&ro)
            .status()
            .is_ok_and(|s| s.success())
    } else {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).is_ok()
    };
    // Unmounted however the checks end.
    let mounted = (made && root).then(|| Unmount(ro.clone()));
    if made {
        refused_naming(&dir, "read-only", "cannot be written (its lock .lock)");
        refused_naming(&dir, "read-only/out", "cannot be made");
    } else {
        println!("no read-only folder could be made here: that half is not checked");
    }
    drop(mounted);
    std::fs::remove_dir_all(&dir).ok();
}
