//! Runs killed or interrupted at several points — between steps, inside a checkpoint write,
//! between the two renames of a re-saved checkpoint — and resumed with `--resume` end with the
//! parameters, optimiser state, metrics and CMF-SIM schedule of a run that never stopped, bit
//! for bit (same seed, same thread count); every file left in the folder parses.
//!
//! The release binary is driven as a user would; `COLORVISION_FAULT` (see
//! `colorvision::interrupt`) makes the process abort (as under SIGKILL) or receive a stop
//! request at a named point. One test sends a real SIGINT.

#[path = "../common/mod.rs"]
mod common;
mod harness;
mod kill_points;
mod stop_stages;

use common::{text, BIN};
use harness::*;
use std::path::Path;
use std::process::Command;

const ABORT: i32 = 134;
const STOPPED: i32 = 130;

#[test]
fn killed_between_steps_resumes_bit_identically() {
    check_scenario("between", &[("abort@step:6", ABORT)]);
}

#[test]
fn killed_inside_checkpoint_writes_resumes_bit_identically() {
    check_scenario(
        "inside_write",
        &[
            ("abort@params-written:8", ABORT),
            ("abort@files-written:12", ABORT),
        ],
    );
}

#[test]
fn interrupted_before_and_after_measurements_resumes_bit_identically() {
    check_scenario(
        "interrupted",
        &[
            ("interrupt@step:5", STOPPED),
            ("interrupt@measured:6", STOPPED),
            ("abort@measured:12", ABORT),
        ],
    );
}

#[test]
fn killed_between_the_renames_of_a_resaved_checkpoint_resumes_bit_identically() {
    // Step 8 is checkpointed before its measurements; the stop after them re-saves it, and
    // the process dies with the old folder moved aside and the new one not yet in place.
    check_scenario(
        "resave",
        &[("interrupt@measured:8,abort@old-moved-aside:8", ABORT)],
    );
}

#[test]
fn a_damaged_checkpoint_falls_back_to_the_one_before_and_says_so() {
    let dir = scratch("damaged");
    let o = start(&dir, "run", Some("abort@step:10"));
    assert_eq!(exit_code(&o), Some(ABORT), "{}", text(&o));
    let params = dir.join("out/checkpoints/step_00000008/params.safetensors");
    let mut bytes = std::fs::read(&params).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x01;
    std::fs::write(&params, bytes).unwrap();
    let o = resume(&dir, "run");
    let log = text(&o);
    assert!(o.status.success(), "{log}");
    assert!(
        log.contains("step_00000008 does not load") && log.contains("SHA-256"),
        "{log}"
    );
    assert!(log.contains("resuming at step 5"), "{log}");
    let got = outcome(&dir.join("out"));
    assert!(got.0 == reference().0, "final parameters differ");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn sigint_finishes_the_step_writes_a_checkpoint_and_resume_continues_from_it() {
    let dir = scratch("sigint");
    let config = CONFIG.replace("steps = 12", "steps = 100000");
    std::fs::write(dir.join("config.toml"), config).unwrap();
    let child = Command::new(BIN)
        .args(["train", "--config", "config.toml", "--out", "out"])
        .current_dir(&dir)
        .env_remove("COLORVISION_FAULT")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let first = dir.join("out/checkpoints/step_00000008");
    let started = std::time::Instant::now();
    while !first.exists() {
        assert!(started.elapsed().as_secs() < 60, "no checkpoint after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    let log = text(&o);
    assert_eq!(exit_code(&o), Some(STOPPED), "{log}");
    assert!(
        log.contains("SIGINT received")
            && log.contains("stopped by SIGINT after step")
            && log.contains("colorvision resume out"),
        "{log}"
    );
    assert_files_parse(&dir.join("out"), false);
    // The folder is this run's: a plain rerun is refused, --resume continues (here to a
    // shorter end is not allowed: the settings must agree).
    let o = colorvision(
        &dir,
        &["train", "--config", "config.toml", "--out", "out"],
        None,
    );
    assert!(text(&o).contains("--resume"), "{}", text(&o));
    let o = colorvision(
        &dir,
        &[
            "train",
            "--config",
            "config.toml",
            "--out",
            "out",
            "--resume",
            "--steps",
            "9",
        ],
        None,
    );
    assert!(
        text(&o).contains("holds another run (`steps`"),
        "{}",
        text(&o)
    );
    let stopped_at: u64 = log
        .split("after step ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .expect("the message names the step");
    let next = stopped_at + 3;
    let o = colorvision(
        &dir,
        &["resume", "out"],
        Some(&format!("interrupt@step:{next}")),
    );
    let log = text(&o);
    assert_eq!(exit_code(&o), Some(STOPPED), "{log}");
    assert!(
        log.contains(&format!("resuming at step {stopped_at}")),
        "{log}"
    );
    assert!(
        dir.join(format!("out/checkpoints/step_{next:08}")).is_dir(),
        "{log}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_continued_run_killed_in_its_second_stage_resumes_bit_identically() {
    // `boost`: 4 steps on LMS, then the same cortex 4 more on LMSQ (Adam recreated); the
    // fault's step counts the cortex's updates, so step 6 is inside the second stage.
    let stage = "out/after_LMSQ_Q_506/checkpoints/step_00000008/params.safetensors";
    let args = ["experiment", "boost", "--config", "c.toml", "--out", "out"];
    let config = "preset = \"tiny\"\nsteps = 4\n[cortex.train]\ncheckpoint_every_steps = 1\n";
    let reference = scratch("boost_reference");
    std::fs::write(reference.join("c.toml"), config).unwrap();
    let o = colorvision(&reference, &args, None);
    assert!(o.status.success(), "{}", text(&o));
    let dir = scratch("boost");
    std::fs::write(dir.join("c.toml"), config).unwrap();
    let o = colorvision(&dir, &args, Some("abort@step:6"));
    assert_eq!(exit_code(&o), Some(ABORT), "{}", text(&o));
    let mut resumed = args.to_vec();
    resumed.push("--resume");
    let o = colorvision(&dir, &resumed, None);
    let log = text(&o);
    assert!(o.status.success(), "{log}");
    assert!(log.contains("before_LMS holds this run, finished"), "{log}");
    assert!(log.contains("resuming at step 1"), "{log}");
    assert_files_parse(&dir.join("out"), false);
    assert!(
        std::fs::read(dir.join(stage)).unwrap() == std::fs::read(reference.join(stage)).unwrap(),
        "the continued stage's final parameters differ"
    );
    std::fs::remove_dir_all(reference).ok();
    std::fs::remove_dir_all(dir).ok();
}

/// A run under learning rule `rule` killed at step 6 and resumed ends with the final
/// parameters and optimiser state of the run that never stopped; its log names the rule.
fn a_rule_run_resumes_bit_identically(rule: &str, logged: &str) {
    let config = format!("learning_rule = \"{rule}\"\n{CONFIG}");
    let final_state = |out: &Path| {
        let ck = out.join("checkpoints").join("step_00000012");
        (
            std::fs::read(ck.join("params.safetensors")).unwrap(),
            std::fs::read(ck.join("optim.safetensors")).unwrap(),
        )
    };
    let reference = scratch(&format!("{rule}_reference"));
    let o = start_with(&reference, "train", &config, None);
    assert!(o.status.success(), "{}", text(&o));
    let dir = scratch(rule);
    let o = start_with(&dir, "train", &config, Some("abort@step:6"));
    assert_eq!(exit_code(&o), Some(ABORT), "{}", text(&o));
    assert_files_parse(&dir.join("out"), true);
    let o = resume(&dir, "train");
    let log = text(&o);
    assert!(o.status.success(), "{log}");
    assert!(log.contains("resuming at step 4"), "{log}");
    assert!(log.contains(logged), "{log}");
    assert_files_parse(&dir.join("out"), false);
    let (got, want) = (
        final_state(&dir.join("out")),
        final_state(&reference.join("out")),
    );
    assert!(got.0 == want.0, "{rule}: final parameters differ");
    assert!(got.1 == want.1, "{rule}: final optimiser state differs");
    std::fs::remove_dir_all(reference).ok();
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_feedback_alignment_run_killed_between_steps_resumes_bit_identically() {
    // The fixed random backward weights are scaled to the parameters the run started from;
    // the run resumed at step 4 must draw the same ones, not ones scaled to step 4's weights.
    a_rule_run_resumes_bit_identically("feedback-alignment", "feedback alignment");
}

#[test]
fn a_direct_feedback_alignment_run_killed_between_steps_resumes_bit_identically() {
    // The feedback matrices depend on the seed, the tags and the shapes only.
    a_rule_run_resumes_bit_identically("direct-feedback-alignment", "direct feedback alignment");
}

#[test]
fn a_kolen_pollack_run_killed_between_steps_resumes_bit_identically() {
    // B is learned: the resumed run must read it (and its Adam moments) from the checkpoint.
    a_rule_run_resumes_bit_identically("kolen-pollack", "Kolen-Pollack");
}

#[test]
fn a_forward_forward_run_killed_between_steps_resumes_bit_identically() {
    // The wrong motions of the negative data come from the batch: the data stream's resume.
    a_rule_run_resumes_bit_identically("forward-forward", "forward-forward");
}

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    n.sort();
    n
}

#[test]
fn killed_at_its_first_write_the_folder_is_rerun_or_resumed() {
    let dir = scratch("first_write");
    let o = start(&dir, "train", Some("abort@lock-written:0"));
    assert_eq!(exit_code(&o), Some(ABORT), "{}", text(&o));
    let left = names(&dir.join("out"));
    assert!(
        !left.is_empty()
            && left
                .iter()
                .all(|n| n.starts_with('.') && n.contains(".tmp-")),
        "{left:?}"
    );
    // `resume` says the run was never started and removes what the killed start left.
    let o = colorvision(&dir, &["resume", "out"], None);
    let log = text(&o);
    assert_eq!(exit_code(&o), Some(1), "{log}");
    assert!(
        log.contains("never started") && log.contains("removed"),
        "{log}"
    );
    assert!(names(&dir.join("out")).is_empty(), "{log}");
    // Killed again, the same command run again starts the run and finishes it.
    let o = start(&dir, "train", Some("abort@lock-written:0"));
    assert_eq!(exit_code(&o), Some(ABORT), "{}", text(&o));
    let o = start(&dir, "train", None);
    assert!(o.status.success(), "{}", text(&o));
    assert_files_parse(&dir.join("out"), false);
    // Killed once more elsewhere, `--resume` with the run's settings starts it.
    let args = ["train", "--config", "config.toml", "--out", "again"];
    let o = colorvision(&dir, &args, Some("abort@lock-written:0"));
    assert_eq!(exit_code(&o), Some(ABORT), "{}", text(&o));
    let o = colorvision(&dir, &[&args[..], &["--resume"]].concat(), None);
    let log = text(&o);
    assert!(o.status.success() && log.contains("never started"), "{log}");
    assert_files_parse(&dir.join("again"), false);
    // A temporary a killed writer left beside a finished run goes when it is resumed.
    let stale = dir.join("out/.report.html.tmp-4294967295");
    std::fs::write(&stale, "").unwrap();
    let o = colorvision(&dir, &["resume", "out"], None);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!stale.exists(), "{}", text(&o));
    std::fs::remove_dir_all(dir).ok();
}
