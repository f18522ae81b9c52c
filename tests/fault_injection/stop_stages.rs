//! SIGTERM honoured inside each long stage, not only between training steps: scene drawing,
//! the held-out evaluation and CMF-SIM each check the stop flag in their loops, so a run whose
//! stage would take minutes ends within seconds with exit code 130, a one-line message naming
//! the stage, and its folder as the last checkpoint left it.
//!
//! Each run is given settings that make its stage take minutes; the signal is sent once the
//! stage is under way (what it writes just before shows that). The bound on the time to stop is
//! far above what it takes (about a second) and far below the stage's own length.

use super::common::{self, text};
use super::harness::{exit_code, scratch};
use std::path::Path;
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

/// A stop must end the process within this long; the stages run for minutes.
const BOUND: Duration = Duration::from_secs(20);

/// Runs `COMMAND --config c.toml --out out` with `config` in `dir`, sends SIGTERM `after` once
/// `started(dir)` holds, and returns the output and the time from the signal to the exit.
fn sigterm_during(
    dir: &Path,
    command: &str,
    config: &str,
    started: impl Fn(&Path) -> bool,
    after: Duration,
) -> (Output, Duration) {
    std::fs::write(dir.join("c.toml"), config).unwrap();
    let mut child = common::command(dir, &[command, "--config", "c.toml", "--out", "out"], None)
        // The stage is stopped long before it takes the memory its settings would.
        .env("COLORVISION_MEMORY_LIMIT_MIB", "0")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let begun = Instant::now();
    while !started(dir) {
        let ended = child.try_wait().unwrap().is_some();
        if ended || begun.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!(
                "the stage did not start: {}",
                text(&child.wait_with_output().unwrap())
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(after);
    let kill = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let sent = Instant::now();
    let o = child.wait_with_output().unwrap();
    (o, sent.elapsed())
}

fn assert_stopped_within_bound(o: &Output, took: Duration, stage: &str) {
    let log = text(o);
    assert_eq!(exit_code(o), Some(130), "{log}");
    assert!(
        took < BOUND,
        "{stage}: stopped {took:?} after SIGTERM: {log}"
    );
    let said = format!("stopped by SIGTERM during {stage}");
    assert!(log.contains(&said), "{log}");
}

#[test]
fn sigterm_stops_scene_generation_within_seconds_and_leaves_no_folder() {
    let dir = scratch("stop_scenes");
    // 20 000 tiles of the tiny eye take minutes to draw.
    let config = "preset = \"tiny\"\nsteps = 2\n[retina.scenes]\ntiles = 20000\n";
    // The folder appears when the lock is taken, just before the scenes are drawn.
    let (o, took) = sigterm_during(
        &dir,
        "train",
        config,
        |d| d.join("out").exists(),
        Duration::from_millis(500),
    );
    assert_stopped_within_bound(&o, took, "scene generation");
    assert!(!dir.join("out").exists(), "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn sigterm_stops_the_heldout_evaluation_within_seconds() {
    let dir = scratch("stop_eval");
    // 10 000 held-out batches at step 1 take minutes.
    let config = "preset = \"tiny\"\nsteps = 4\n[cortex.train]\ncheckpoint_every_steps = 1\n\
                  [schedule]\neval_every_steps = 2\neval_batches = 10000\n";
    // Step 1's checkpoint is written before step 2 and its evaluation.
    let (o, took) = sigterm_during(
        &dir,
        "train",
        config,
        |d| d.join("out/checkpoints/step_00000001").exists(),
        Duration::from_millis(1000),
    );
    assert_stopped_within_bound(&o, took, "the held-out evaluation");
    assert!(text(&o).contains("colorvision resume out"), "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn sigterm_stops_cmf_sim_within_seconds() {
    let dir = scratch("stop_cmf");
    // The analytic LMS observer is 3-D: with at most 2 primaries every K fails, each after a
    // million primary sets, which takes hours.
    let args = [
        "cmf-sim",
        "--observer",
        "analytic",
        "--preset",
        "tiny",
        "--set",
        "cmf_sim.max_primaries=2",
        "--set",
        "cmf_sim.sets_per_k=1000000",
        "--out",
        "out",
    ];
    let child = common::command(&dir, &args, None)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Nothing is written until the measurement ends: the signal goes once it is well under way.
    std::thread::sleep(Duration::from_secs(3));
    let kill = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let sent = Instant::now();
    let o = child.wait_with_output().unwrap();
    assert_stopped_within_bound(&o, sent.elapsed(), "CMF-SIM");
    assert!(!dir.join("out").exists(), "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}

/// A stop must end a process whose stage does not check the stop flag (the deadline,
/// `colorvision::interrupt::STOP_DEADLINE`, 4 s) within this long.
const DEADLINE_BOUND: Duration = Duration::from_secs(8);

/// Asserts a process the deadline ended: exit 130 within [`DEADLINE_BOUND`] of the signal,
/// the stop message, and no temporary or lock left in `out` (when there is one).
fn assert_left_by_the_deadline(o: &Output, took: Duration, out: &Path) {
    let log = text(o);
    assert_eq!(exit_code(o), Some(130), "{log}");
    assert!(
        took < DEADLINE_BOUND,
        "stopped {took:?} after SIGTERM: {log}"
    );
    assert!(log.contains("stopped by SIGTERM during"), "{log}");
    if out.exists() {
        super::harness::assert_files_parse(out, false);
    }
}

#[test]
fn sigterm_inside_a_training_step_that_never_checks_leaves_by_the_deadline() {
    let dir = scratch("stop_wide_step");
    // P's couplings at their widest (4096): the first step takes minutes and checks no flag.
    let config = "preset = \"tiny\"\nsteps = 2\n[cortex.p]\nhidden = 4096\n";
    // The folder's config.toml is in place just before the first step.
    let (o, took) = sigterm_during(
        &dir,
        "train",
        config,
        |d| d.join("out/config.toml").exists(),
        Duration::from_millis(1500),
    );
    assert_left_by_the_deadline(&o, took, &dir.join("out"));
    assert!(text(&o).contains("colorvision resume out"), "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}
