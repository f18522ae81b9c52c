//! A fresh run killed at each of its file writes and renames (`COLORVISION_FAULT=abort@write:N`
//! and `abort@rename:N`: the process dies once the Nth file's bytes are in its temporary, or
//! once the Nth file is in place, as under SIGKILL) leaves a folder that `colorvision resume`
//! continues, or, when the kill came before the run's `config.toml` was in place, one that
//! `resume` calls never started and the same command starts afresh. Either way the run then
//! ends with every file a run that never stopped has, no temporary and no lock left, and its
//! `run.json`, so that `resume --steps` extends it.
//!
//! `scripts/kill-walk.sh` walks the same points with a real SIGKILL (strace's fault injection)
//! at every `write(2)` of a longer run, outside CI.

use super::common::text;
use super::harness::{assert_files_parse, colorvision, exit_code, scratch};
use std::collections::BTreeSet;
use std::path::Path;

/// Two tiny steps, a checkpoint each, CMF-SIM and pictures at the end: every kind of file a run
/// writes.
const CONFIG: &str = r#"preset = "tiny"
steps = 2
[cortex.train]
checkpoint_every_steps = 1
"#;

/// Every file and folder under `dir`, relative to it.
fn file_set(dir: &Path) -> BTreeSet<String> {
    fn walk(root: &Path, dir: &Path, into: &mut BTreeSet<String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(root).unwrap().display().to_string();
            into.insert(rel);
            if path.is_dir() {
                walk(root, &path, into);
            }
        }
    }
    let mut set = BTreeSet::new();
    walk(dir, dir, &mut set);
    set
}

fn start(dir: &Path, command: &str, fault: Option<&str>) -> std::process::Output {
    colorvision(dir, &[command, "--config", "c.toml", "--out", "out"], fault)
}

/// Kills a fresh run at the `n`th `kind` (`write` or `rename`), then resumes it (or starts it
/// again when `resume` says it never started) and checks the folder against `want`. `false`
/// when the run ended before its `n`th `kind`.
fn kill_and_recover(
    dir: &Path,
    command: &str,
    (kind, n): (&str, u64),
    want: &BTreeSet<String>,
) -> bool {
    let _ = std::fs::remove_dir_all(dir.join("out"));
    let fault = format!("abort@{kind}:{n}");
    let o = start(dir, command, Some(&fault));
    if o.status.success() {
        return false;
    }
    assert_eq!(exit_code(&o), Some(134), "{fault}: {}", text(&o));
    if dir.join("out").exists() {
        assert_files_parse(&dir.join("out"), true);
    }
    let resumed = colorvision(dir, &["resume", "out"], None);
    let log = text(&resumed);
    if !resumed.status.success() {
        assert!(
            log.contains("was never started"),
            "{fault}: resume neither continued the run nor said it never started: {log}"
        );
        let again = start(dir, command, None);
        assert!(
            again.status.success(),
            "{fault}: the run again: {}",
            text(&again)
        );
    }
    let out = dir.join("out");
    assert_files_parse(&out, false);
    let got = file_set(&out);
    assert!(
        &got == want,
        "{fault}: the files differ from an unbroken run's: missing {:?}, extra {:?}\n{log}",
        want.difference(&got).collect::<Vec<_>>(),
        got.difference(want).collect::<Vec<_>>()
    );
    true
}

/// Walks the kill points `points(n)` says to try (N = 1, 2, … until the run ends before its
/// Nth) of each kind, for a fresh `command` run.
fn walk(name: &str, command: &str, points: impl Fn(u64) -> bool) {
    let dir = scratch(name);
    std::fs::write(dir.join("c.toml"), CONFIG).unwrap();
    let o = start(&dir, command, None);
    assert!(o.status.success(), "{}", text(&o));
    let want = file_set(&dir.join("out"));
    assert!(
        want.contains("run.json") && want.contains("summary.json"),
        "{want:?}"
    );
    for kind in ["write", "rename"] {
        let mut n = 1;
        let mut tried = 0;
        while !points(n) || kill_and_recover(&dir, command, (kind, n), &want) {
            tried += usize::from(points(n));
            n += 1;
        }
        assert!(n > 10, "the run wrote only {} files", n - 1);
        println!(
            "{command}: {tried} of {} {kind} points killed, each recovered",
            n - 1
        );
    }
    // A resumed run keeps its marker, so it can be extended.
    let o = colorvision(&dir, &["resume", "out", "--steps", "3"], None);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}

/// The start of a run (its lock, `run.json`, `config.toml`, the first step's files: where a
/// killed start once left a folder `resume` refused) at every point, the rest at every third.
#[test]
fn a_run_killed_at_its_writes_and_renames_resumes_to_the_full_file_set() {
    walk("kill_points", "train", |n| n <= 8 || n % 3 == 0);
}

/// Every point of a run with CMF-SIM (about 35 writes and 38 renames, some 4 minutes):
/// `cargo test --release --test fault_injection -- --ignored at_every_write`.
#[test]
#[ignore]
fn a_run_killed_at_every_write_and_rename_resumes_to_the_full_file_set() {
    walk("kill_points_all", "run", |_| true);
}

/// A run stopped between its `summary.json` and its `report.html` (its last two writes) is
/// finished: `resume` writes the missing report.
#[test]
fn resuming_a_finished_run_without_its_report_writes_the_report() {
    let dir = scratch("kill_report");
    std::fs::write(dir.join("c.toml"), CONFIG).unwrap();
    let o = start(&dir, "train", None);
    assert!(o.status.success(), "{}", text(&o));
    let report = dir.join("out/report.html");
    let before = std::fs::read(&report).unwrap();
    std::fs::remove_file(&report).unwrap();
    let o = colorvision(&dir, &["resume", "out"], None);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read(&report).unwrap(), before, "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}
