//! The harness of the fault-injection tests: the release binary driven in a scratch folder
//! (optionally with a `COLORVISION_FAULT`), the outcome an uninterrupted run must match, and
//! the checks that every file left behind parses and that printed margins are the measured ones.

use super::common::{self, text};
use std::path::{Path, PathBuf};
use std::process::Output;

/// 12 tiny steps; checkpoints every 4; held-out evaluation every 3, pictures every 6 and
/// CMF-SIM at step 5 and the end, so every stream and schedule crosses a resume.
pub const CONFIG: &str = r#"preset = "tiny"
steps = 12
[cortex.train]
checkpoint_every_steps = 4
[schedule]
eval_every_steps = 3
pictures_every_steps = 6
cmf_extra_steps = [5]
"#;

pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cv_fault_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn colorvision(dir: &Path, args: &[&str], fault: Option<&str>) -> Output {
    common::command(dir, args, fault)
        .output()
        .expect("the binary runs")
}

/// The exit code, or 128 + the signal that ended the process (as a shell reports it).
pub fn exit_code(o: &Output) -> Option<i32> {
    use std::os::unix::process::ExitStatusExt;
    o.status
        .code()
        .or_else(|| o.status.signal().map(|s| 128 + s))
}

/// A run of `command` in `dir/out`, optionally with a fault.
pub fn start(dir: &Path, command: &str, fault: Option<&str>) -> Output {
    start_with(dir, command, CONFIG, fault)
}

/// A run of `command` with the settings `config` in `dir/out`, optionally with a fault.
pub fn start_with(dir: &Path, command: &str, config: &str, fault: Option<&str>) -> Output {
    std::fs::write(dir.join("config.toml"), config).unwrap();
    colorvision(
        dir,
        &[command, "--config", "config.toml", "--out", "out"],
        fault,
    )
}

pub fn resume(dir: &Path, command: &str) -> Output {
    colorvision(dir, &[command, "--out", "out", "--resume"], None)
}

/// What must match an uninterrupted run: the final checkpoint's parameters and optimiser state
/// (file bytes), metrics without the step-time column, the CMF-SIM measurements (step,
/// dimension), the steps.
pub type Outcome = (Vec<u8>, Vec<u8>, String, Vec<(u64, u64)>, u64);

pub fn outcome(out: &Path) -> Outcome {
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
pub fn assert_files_parse(dir: &Path, temporaries_allowed: bool) {
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

pub fn reference() -> &'static Outcome {
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
pub fn assert_margins_printed(stdout: &str, out: &Path, step: u64) {
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
pub fn check_scenario(name: &str, faults: &[(&str, i32)]) {
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
