//! The memory estimate a run prints before it allocates anything (`science::budget`) against
//! the peak resident memory the run then takes: within ±30 % at the `tiny` and `quick` presets'
//! defaults (where its fixed coefficients were measured), and at least the peak and at most
//! 1.3 × it where a setting makes a part grow (`simulate`'s tiles, the analytic observer's
//! location pairs); a run over its limit (`COLORVISION_MEMORY_LIMIT_MIB`) is refused with one
//! line naming the settings that drive the estimate, and makes no folder.
//!
//! The peak is the child's own (`wait4`'s resource usage of that process, `ru_maxrss`).

#[path = "common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::Stdio;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cv_memory_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `colorvision ARGS` in `dir` to the end; its stdout and its peak resident memory, MiB.
// The child is waited for with `wait4`, which also reports its resource usage.
#[allow(clippy::zombie_processes)]
fn peak_of(dir: &Path, args: &[&str]) -> (String, f64) {
    let log = dir.join("stdout.txt");
    let child = common::command(dir, args, None)
        .stdout(std::fs::File::create(&log).unwrap())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: `rusage` is plain data, zeroed is a valid value; `wait4` writes into both
    // out-parameters, which live for the call.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "{args:?} failed: {}",
        std::fs::read_to_string(&log).unwrap()
    );
    // Linux reports ru_maxrss in KiB.
    (
        std::fs::read_to_string(&log).unwrap(),
        usage.ru_maxrss as f64 / 1024.0,
    )
}

/// The estimate the run printed, MiB.
fn printed_estimate(stdout: &str) -> f64 {
    stdout
        .split("estimated peak ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no estimate in:\n{stdout}"))
}

/// Runs each case and checks its printed estimate against its peak with `holds`.
fn check_cases(label: &str, cases: &[(&str, &[&str])], holds: impl Fn(f64, f64) -> bool) {
    let dir = scratch(label);
    for (name, args) in cases {
        let out = format!("out_{}", name.replace([' ', ','], "_"));
        let args: Vec<&str> = args.iter().copied().chain(["--out", &out]).collect();
        let (stdout, peak) = peak_of(&dir, &args);
        let estimate = printed_estimate(&stdout);
        println!("{name}: estimated {estimate:.0} MiB, peak {peak:.0} MiB");
        assert!(
            holds(estimate, peak),
            "{name}: estimated {estimate} MiB, peak {peak} MiB"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

/// The presets' defaults, where the fixed coefficients were measured: within ±30 %.
#[test]
fn the_estimate_is_within_30_percent_of_the_peak_at_the_presets() {
    let cases: [(&str, &[&str]); 3] = [
        ("tiny", &["train", "--preset", "tiny", "--steps", "2"]),
        // The preset's own length: a cortex of a few steps fails CMF-SIM's base test and is
        // never searched, so its peak would miss the search the estimate counts.
        ("tiny with CMF-SIM", &["run", "--preset", "tiny"]),
        ("quick", &["train", "--preset", "quick", "--steps", "2"]),
    ];
    check_cases("presets", &cases, |e, p| (e / p - 1.0).abs() <= 0.30);
}

/// `average` of three checkpoints of a `tiny` run (CMF-SIM, the hidden measures and the two
/// checkpoints held beside the last): within ±30 %.
#[test]
fn the_estimate_of_average_is_within_30_percent_of_its_peak() {
    let dir = scratch("average");
    peak_of(
        &dir,
        &[
            "train",
            "--preset",
            "tiny",
            "--out",
            "run",
            "--set",
            "cortex.train.checkpoint_every_steps=100",
        ],
    );
    let (stdout, peak) = peak_of(&dir, &["average", "--run", "run", "--steps", "100,200,300"]);
    let estimate = printed_estimate(&stdout);
    println!("average: estimated {estimate:.0} MiB, peak {peak:.0} MiB");
    assert!(
        (estimate / peak - 1.0).abs() <= 0.30,
        "average: estimated {estimate} MiB, peak {peak} MiB"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// Where a setting makes a part grow (docs/memory-tops.md): peak ≤ estimate ≤ 1.3 × peak.
#[test]
fn the_estimate_bounds_the_peak_where_a_part_grows() {
    let cases: [(&str, &[&str]); 2] = [
        (
            "simulate, 500 tiles",
            &[
                "simulate",
                "--preset",
                "tiny",
                "--set",
                "retina.scenes.tiles=500",
            ],
        ),
        (
            "analytic CMF-SIM, 4 096 location pairs",
            &[
                "cmf-sim",
                "--observer",
                "analytic",
                "--preset",
                "tiny",
                "--set",
                "cmf_sim.location_pairs=4096",
            ],
        ),
    ];
    check_cases("tops", &cases, |e, p| p <= e && e <= 1.3 * p);
}

/// Runs `colorvision ARGS` in `dir` under a limit of 1 MiB: it must be refused (exit 1) naming
/// the limit; its stderr.
fn refused_at_one_mib(dir: &Path, args: &[&str]) -> String {
    let o = common::command(dir, args, None)
        .env("COLORVISION_MEMORY_LIMIT_MIB", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
    assert!(
        err.contains("COLORVISION_MEMORY_LIMIT_MIB=1"),
        "{args:?}: {err}"
    );
    err
}

#[test]
fn a_run_over_its_memory_limit_is_refused_naming_what_drives_it() {
    let dir = scratch("limit");
    let o = common::command(
        &dir,
        &["train", "--preset", "tiny", "--steps", "2", "--out", "out"],
        None,
    )
    .args(["--set", "retina.scenes.tiles=100000"])
    .env("COLORVISION_MEMORY_LIMIT_MIB", "4096")
    .output()
    .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("COLORVISION_MEMORY_LIMIT_MIB=4096") && err.contains("retina.scenes.tiles"),
        "{err}"
    );
    assert!(!dir.join("out").exists(), "{err}");
    // `scope` and `average` of a finished run check their estimates before they write anything.
    let o = common::command(
        &dir,
        &["train", "--preset", "tiny", "--steps", "2", "--out", "run"],
        None,
    )
    .args(["--set", "cortex.train.checkpoint_every_steps=1"])
    .output()
    .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = refused_at_one_mib(&dir, &["scope", "--run", "run"]);
    assert!(err.contains("held-out samples"), "{err}");
    assert!(!dir.join("run/scope").exists(), "{err}");
    // `average` counts the checkpoints it holds beside the last.
    let err = refused_at_one_mib(&dir, &["average", "--run", "run", "--steps", "1,2"]);
    assert!(
        err.contains("the other checkpoints averaged") && err.contains("CMF-SIM decodes"),
        "{err}"
    );
    assert!(!dir.join("run/average").exists(), "{err}");
    let o = common::command(&dir, &["train", "--preset", "tiny", "--out", "out"], None)
        .env("COLORVISION_MEMORY_LIMIT_MIB", "lots")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(
        err.contains("COLORVISION_MEMORY_LIMIT_MIB") && o.status.code() == Some(1),
        "{err}"
    );
    std::fs::remove_dir_all(dir).ok();
}
