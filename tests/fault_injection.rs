//! Runs killed or interrupted at several points — between steps, inside a checkpoint write,
//! between the two renames of a re-saved checkpoint — and resumed with `--resume` end with the
//! parameters, optimiser state, metrics and CMF-SIM schedule of a run that never stopped, bit
//! for bit (same seed, same thread count); every file left in the folder parses.
//!
//! The release binary is driven as a user would; `COLORVISION_FAULT` (see
//! `colorvision::interrupt`) makes the process abort (as under SIGKILL) or receive a stop
//! request at a named point. One test sends a real SIGINT.

mod common;

use common::text;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::BIN;

/// 12 tiny steps; checkpoints every 4; held-out evaluation every 3, pictures every 6 and
/// CMF-SIM at step 5 and the end, so every stream and schedule crosses a resume.
const CONFIG: &str = r#"preset = "tiny"
steps = 12
[cortex.train]
checkpoint_every_steps = 4
[schedule]
eval_every_steps = 3
pictures_every_steps = 6
cmf_extra_steps = [5]
"#;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cv_fault_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn colorvision(dir: &Path, args: &[&str], fault: Option<&str>) -> Output {
    common::command(dir, args, fault)
        .output()
        .expect("the binary runs")
}

/// The exit code, or 128 + the signal that ended the process (as a shell reports it).
fn exit_code(o: &Output) -> Option<i32> {
    use std::os::unix::process::ExitStatusExt;
    o.status
        .code()
        .or_else(|| o.status.signal().map(|s| 128 + s))
}

/// A run of `command` in `dir/out`, optionally with a fault.
fn start(dir: &Path, command: &str, fault: Option<&str>) -> Output {
    start_with(dir, command, CONFIG, fault)
}

/// A run of `command` with the settings `config` in `dir/out`, optionally with a fault.
fn start_with(dir: &Path, command: &str, config: &str, fault: Option<&str>) -> Output {
    std::fs::write(dir.join("config.toml"), config).unwrap();
    colorvision(
        dir,
        &[command, "--config", "config.toml", "--out", "out"],
        fault,
    )
}

fn resume(dir: &Path, command: &str) -> Output {
    colorvision(dir, &[command, "--out", "out", "--resume"], None)
}

/// What must match an uninterrupted run: the final checkpoint's parameters and optimiser state
/// (file bytes), metrics without the step-time column, the CMF-SIM measurements (step,
/// dimension), the steps.
type Outcome = (Vec<u8>, Vec<u8>, String, Vec<(u64, u64)>, u64);

fn outcome(out: &Path) -> Outcome {
    let ck = out.join("checkpoints").join("step_00000012");
    let metrics = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    let metrics: String = metrics
        .lines()
        .map(|l| {
            let mut c: Vec<&str> = l.split(',').collect();
            c.remove(3);
            c.join(",") + "\n"
        })
        .collect();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let dims = summary["dimension_over_steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            (
                d["step"].as_u64().unwrap(),
                d["dimension"].as_u64().unwrap(),
            )
        })
        .collect();
    (
        std::fs::read(ck.join("params.safetensors")).unwrap(),
        std::fs::read(ck.join("optim.safetensors")).unwrap(),
        metrics,
        dims,
        summary["steps"].as_u64().unwrap(),
    )
}

/// Every file under `dir` parses by its kind. Hidden temporaries (`.NAME.tmp-PID`, a
/// checkpoint moved aside) and the lock of the killed process (`.lock`) may remain after a
/// kill, and are removed or taken over when the run resumes: with `temporaries_allowed` false
/// there must be none.
fn assert_files_parse(dir: &Path, temporaries_allowed: bool) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let temporary = name.contains(".tmp")
            || name.contains(".old-")
            || name.contains("staging")
            || name == ".lock";
        assert!(
            temporaries_allowed || !temporary,
            "temporary left behind: {}",
            path.display()
        );
        if temporary {
            assert!(name.starts_with('.'), "a temporary must be hidden: {name}");
            continue;
        }
        if path.is_dir() {
            assert_files_parse(&path, temporaries_allowed);
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        let what = path.display();
        match path.extension().and_then(|e| e.to_str()).unwrap_or("") {
            "json" => {
                serde_json::from_slice::<serde_json::Value>(&bytes)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
            }
            "toml" => {
                toml::from_str::<toml::Value>(std::str::from_utf8(&bytes).unwrap())
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
            }
            "csv" => {
                let text = std::str::from_utf8(&bytes).unwrap();
                let width = text.lines().next().unwrap().split(',').count();
                assert!(
                    text.ends_with('\n') && text.lines().all(|l| l.split(',').count() == width),
                    "{what}: ragged CSV"
                );
            }
            "svg" => {
                let t = std::str::from_utf8(&bytes).unwrap().trim_end();
                assert!(t.ends_with("</svg>"), "{what}: truncated SVG");
            }
            "html" => {
                let t = std::str::from_utf8(&bytes).unwrap();
                assert!(
                    t.starts_with("<!DOCTYPE html>") && t.trim_end().ends_with("</html>"),
                    "{what}: truncated HTML"
                );
            }
            "png" => {
                let mut r = png::Decoder::new(std::io::Cursor::new(bytes))
                    .read_info()
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                let mut buf = vec![0; r.output_buffer_size().unwrap()];
                r.next_frame(&mut buf)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
            }
            "safetensors" => {
                autodiff::params::read_safetensors::<f32>(&path)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
            }
            other => panic!("{what}: unexpected file type `{other}`"),
        }
    }
}

fn reference() -> &'static Outcome {
    static REF: std::sync::OnceLock<Outcome> = std::sync::OnceLock::new();
    REF.get_or_init(|| {
        let dir = scratch("reference");
        let o = start(&dir, "run", None);
        assert!(o.status.success(), "{}", text(&o));
        let r = outcome(&dir.join("out"));
        assert_eq!(
            r.3,
            vec![(5, r.3[0].1), (12, r.3[1].1)],
            "CMF-SIM at 5 and 12"
        );
        assert_margins_printed(&String::from_utf8_lossy(&o.stdout), &dir.join("out"), 5);
        std::fs::remove_dir_all(dir).ok();
        r
    })
}

/// The line a measurement during training prints carries the margins its `cmf_sim.json`
/// holds: per K tried, "K<k> <worst error / threshold>".
fn assert_margins_printed(stdout: &str, out: &Path, step: u64) {
    let head = format!("step {step}: CMF-SIM dimension");
    let line = stdout
        .lines()
        .find(|l| l.trim_start().starts_with(&head))
        .unwrap_or_else(|| panic!("no `{head}` line in:\n{stdout}"));
    let json = out.join(format!("cmf_sim/step_{step:06}/cmf_sim.json"));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let per_k = r["per_k"].as_array().expect("per_k");
    assert!(!per_k.is_empty(), "CMF-SIM tried no K");
    let margins: Vec<String> = per_k
        .iter()
        .map(|q| {
            let (k, ratio) = (
                &q["n_primaries"],
                q["converged_worst_ratio"].as_f64().unwrap(),
            );
            format!("K{k} {ratio:.2}")
        })
        .collect();
    let want = format!("({}; ", margins.join(", "));
    assert!(line.contains(&want), "`{line}` lacks `{want}`");
}

/// Runs with `faults` (one process each, in order), then resumes until finished, and checks
/// the result against the uninterrupted run.
fn check_scenario(name: &str, faults: &[(&str, i32)]) {
    let dir = scratch(name);
    for (i, (fault, code)) in faults.iter().enumerate() {
        let o = if i == 0 {
            start(&dir, "run", Some(fault))
        } else {
            colorvision(&dir, &["run", "--out", "out", "--resume"], Some(fault))
        };
        assert_eq!(exit_code(&o), Some(*code), "{name}, {fault}: {}", text(&o));
        assert_files_parse(&dir.join("out"), true);
    }
    let o = resume(&dir, "run");
    assert!(o.status.success(), "{name}: resume failed: {}", text(&o));
    assert_files_parse(&dir.join("out"), false);
    let got = outcome(&dir.join("out"));
    let want = reference();
    assert!(got.0 == want.0, "{name}: final parameters differ");
    assert!(got.1 == want.1, "{name}: final optimiser state differs");
    assert_eq!(got.2, want.2, "{name}: metrics differ");
    assert_eq!(got.3, want.3, "{name}: CMF-SIM schedule differs");
    assert_eq!(got.4, want.4, "{name}: steps differ");
    std::fs::remove_dir_all(dir).ok();
}

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
fn a_forward_forward_run_killed_between_steps_resumes_bit_identically() {
    // The wrong motions of the negative data come from the batch: the data stream's resume.
    a_rule_run_resumes_bit_identically("forward-forward", "forward-forward");
}
