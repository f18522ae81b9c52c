//! `colorvision sweep --local -j N DIR`: every task of a sweep folder on this machine, `N` at
//! a time, each by running `DIR/sweep.sbatch` with `SLURM_ARRAY_TASK_ID` set, as Slurm would;
//! its output is appended to `DIR/logs/task-<index>.log`, as under Slurm.
//!
//! Each task gets `max(1, CPUs / N)` threads (`RAYON_NUM_THREADS`, unless already set): a run
//! resumed later must use the same thread count to continue bit-identically. Ctrl-C reaches
//! every task (one process group): each checkpoints and stops, no further task starts, and the
//! same command continues.

use super::task::Manifest;
use crate::run::error::RunError;
use std::fs::OpenOptions;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// How one task ended.
#[derive(Debug)]
struct Ended {
    index: usize,
    code: Option<i32>,
}

/// Runs every task of the sweep folder `dir`, `jobs` at a time.
pub fn run_local(dir: &Path, jobs: usize) -> Result<(), RunError> {
    let manifest = Manifest::read(dir)?;
    let script = dir.join("sweep.sbatch");
    if !script.is_file() {
        return Err(RunError::Folder {
            path: dir.to_path_buf(),
            reason: "has no sweep.sbatch".into(),
        });
    }
    let exe = std::env::current_exe().map_err(crate::io::fs_err(Path::new("/proc/self/exe")))?;
    let logs = dir.join("logs");
    std::fs::create_dir_all(&logs).map_err(crate::io::fs_err(&logs))?;
    let n = manifest.tasks.len();
    let jobs = jobs.clamp(1, n.max(1));
    let cpus = std::thread::available_parallelism().map_or(1, |c| c.get());
    let threads =
        std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| (cpus / jobs).max(1).to_string());
    println!(
        "colorvision sweep: {n} tasks of {}, {jobs} at a time, {threads} threads each; logs in {}",
        dir.display(),
        logs.display()
    );
    let next = AtomicUsize::new(0);
    let stopping = AtomicBool::new(false);
    let ended = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                if stopping.load(Ordering::SeqCst) || crate::interrupt::requested().is_some() {
                    break;
                }
                let index = next.fetch_add(1, Ordering::SeqCst);
                if index >= n {
                    break;
                }
                let code = run_one(&script, &exe, &threads, &logs, index);
                // A task stopped by a signal (Ctrl-C reached the group): start no other.
                if matches!(code, Some(130) | None) {
                    stopping.store(true, Ordering::SeqCst);
                }
                let folder = &manifest.tasks[index].folder;
                let (log, word) = (logs.join(format!("task-{index}.log")), outcome(code));
                println!("  task {index} {folder}: {word} ({})", log.display());
                ended
                    .lock()
                    .expect("no task panics")
                    .push(Ended { index, code });
            });
        }
    });
    let mut ended = ended.into_inner().expect("no task panics");
    ended.sort_by_key(|e| e.index);
    let mut bad: Vec<String> = ended
        .iter()
        .filter(|e| e.code != Some(0))
        .map(|e| format!("{} ({})", e.index, outcome(e.code)))
        .collect();
    let started: Vec<usize> = ended.iter().map(|e| e.index).collect();
    bad.extend(
        (0..n)
            .filter(|i| !started.contains(i))
            .map(|i| format!("{i} (not started)")),
    );
    if bad.is_empty() {
        println!(
            "all {n} tasks done; table: colorvision gather {}",
            dir.display()
        );
        return Ok(());
    }
    Err(RunError::Folder {
        path: dir.to_path_buf(),
        reason: format!(
            "{} of {n} tasks did not finish: {}; see logs/task-<index>.log, run the same \
             command again to continue them",
            bad.len(),
            bad.join(", ")
        ),
    })
}

fn outcome(code: Option<i32>) -> String {
    match code {
        Some(0) => "done".into(),
        Some(130) => "stopped (checkpointed; exit 130)".into(),
        Some(c) => format!("failed (exit {c})"),
        None => "killed by a signal".into(),
    }
}

/// Runs task `index` through the script; its exit code (`None`: it could not start or a
/// signal ended it).
fn run_one(script: &Path, exe: &Path, threads: &str, logs: &Path, index: usize) -> Option<i32> {
    let log = logs.join(format!("task-{index}.log"));
    let open = || OpenOptions::new().create(true).append(true).open(&log);
    let (Ok(out), Ok(err)) = (open(), open()) else {
        eprintln!("colorvision: cannot open {}", log.display());
        return None;
    };
    Command::new("bash")
        .arg(script)
        .env("SLURM_ARRAY_TASK_ID", index.to_string())
        .env("COLORVISION", exe)
        .env("RAYON_NUM_THREADS", threads)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .status()
        .ok()
        .and_then(|s| s.code())
}
