//! Measuring a finished run (`cmf-sim --run DIR`, `scope --run DIR`) leaves the run's own
//! record byte for byte as it was: without `--out` the measurements land in `DIR/cmf-sim/`
//! and `DIR/scope/`, with `--out X` in `X`, and an `--out` inside the record is refused.

mod common;

use common::{colorvision, scratch_dir, text};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every file under `dir` (relative path → bytes), leaving out the sub-folders named `skip`.
fn snapshot(dir: &Path, skip: &[&str]) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, skip: &[&str], out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let rel = path.strip_prefix(root).unwrap().to_path_buf();
            if skip.iter().any(|s| rel == Path::new(s)) {
                continue;
            }
            if path.is_dir() {
                walk(root, &path, skip, out);
            } else {
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, skip, &mut out);
    out
}

#[test]
fn measurements_of_a_run_never_touch_its_record() {
    let dir = scratch_dir("run_record", "record");
    let o = colorvision(
        &dir,
        &["run", "--preset", "tiny", "--steps", "3", "--out", "run"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let run = dir.join("run");
    for f in ["summary.json", "cmf_sim.json", "pictures"] {
        assert!(run.join(f).exists(), "the run wrote no {f}");
    }
    let before = snapshot(&run, &[]);
    let measurements: [&[&str]; 6] = [
        &["cmf-sim", "--run", "run", "--sets-per-k", "2"],
        &[
            "cmf-sim",
            "--run",
            "run",
            "--sets-per-k",
            "2",
            "--patch-radius-fraction",
            "0.0625",
            "--out",
            "z",
        ],
        &["scope", "--run", "run"],
        &["stiles-burch", "--run", "run"],
        &["cmf-sim", "--run", "run", "--sets-per-k", "2", "--out", "x"],
        &["scope", "--run", "run", "--out", "y"],
    ];
    for args in measurements {
        let o = colorvision(&dir, args);
        assert!(o.status.success(), "{args:?}: {}", text(&o));
    }
    assert_eq!(
        snapshot(&run, &["cmf-sim", "scope", "stiles-burch"]),
        before,
        "the run's own files changed"
    );
    for f in [
        "cmf-sim/cmf_sim.json",
        "pictures/own_S.png",
        "scope/scope.png",
        "stiles-burch/table.json",
        "stiles-burch/trained/stiles_burch.svg",
        "x/cmf_sim.json",
        "y/scope.png",
        "y/own_S.png",
        "y/scope.json",
        "z/cmf_sim.json",
    ] {
        assert!(
            dir.join(if f.starts_with(['x', 'y', 'z']) {
                ""
            } else {
                "run"
            })
            .join(f)
            .is_file(),
            "no {f}"
        );
    }
    for (command, out) in [
        ("cmf-sim", "run"),
        ("scope", "run/pictures"),
        ("scope", "run/./"),
        ("stiles-burch", "run/checkpoints"),
    ] {
        let o = colorvision(&dir, &[command, "--run", "run", "--out", out]);
        assert_eq!(
            o.status.code(),
            Some(1),
            "{command} --out {out}: {}",
            text(&o)
        );
        assert!(text(&o).contains("(--out)"), "{}", text(&o));
    }
    // A patch too large for two to fit in the field is refused by its setting, nothing written.
    let o = colorvision(
        &dir,
        &[
            "cmf-sim",
            "--run",
            "run",
            "--patch-radius-fraction",
            "0.3",
            "--out",
            "w",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("patch_radius_fraction"), "{}", text(&o));
    assert!(!dir.join("w").exists(), "a refused measurement wrote w/");
    // The measurement's own settings apply; the eye's and the cortex's are the run's.
    let o = colorvision(
        &dir,
        &["cmf-sim", "--run", "run", "--sets-per-k", "2", "--set"]
            .into_iter()
            .chain(["cmf_sim.n_test_wavelengths=7", "--out", "v"])
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let measured: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("v/cmf_sim.json")).unwrap())
            .unwrap();
    assert_eq!(measured["test_wavelengths_nm"].as_array().unwrap().len(), 7);
    for (refused, named) in [
        (
            &["--set", "retina.scenes.tetra.fraction=0.5"][..],
            "retina.scenes.tetra.fraction",
        ),
        (&["--preset", "quick"], "--preset"),
        (&["--cones", "LM"], "--cones"),
    ] {
        let args: Vec<&str> = ["cmf-sim", "--run", "run", "--out", "u"]
            .into_iter()
            .chain(refused.iter().copied())
            .collect();
        let o = colorvision(&dir, &args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", text(&o));
        assert!(text(&o).contains(named), "{args:?}: {}", text(&o));
        assert!(
            !dir.join("u").exists(),
            "{args:?}: a refused measurement wrote u/"
        );
    }
    assert_eq!(
        snapshot(&run, &["cmf-sim", "scope", "stiles-burch"]),
        before
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn resume_with_more_steps_extends_a_finished_run_like_a_longer_one() {
    let dir = scratch_dir("run_record", "extend");
    let run = |args: &[&str]| {
        let o = colorvision(&dir, args);
        assert!(o.status.success(), "{args:?}: {}", text(&o));
    };
    run(&[
        "train", "--preset", "tiny", "--steps", "3", "--out", "short",
    ]);
    run(&["resume", "short", "--steps", "5"]);
    run(&["train", "--preset", "tiny", "--steps", "5", "--out", "long"]);
    let losses = |name: &str| -> Vec<String> {
        std::fs::read_to_string(dir.join(name).join("metrics.csv"))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').take(2).collect::<Vec<_>>().join(","))
            .collect()
    };
    assert_eq!(losses("short"), losses("long"), "step,loss rows");
    assert!(dir.join("short/summary_step_3.json").is_file());
    let summary = std::fs::read_to_string(dir.join("short/summary.json")).unwrap();
    assert!(summary.contains("\"steps\": 5"), "{summary}");
    let o = colorvision(&dir, &["resume", "short", "--steps", "4"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("--steps") && text(&o).contains("shortened"),
        "{}",
        text(&o)
    );
    // A finished folder without its per-step log (as a record keeps it) is refused before
    // anything in it changes: its summary and config stay as they were.
    std::fs::remove_file(dir.join("short/metrics.csv")).unwrap();
    let config = std::fs::read_to_string(dir.join("short/config.toml")).unwrap();
    let o = colorvision(&dir, &["resume", "short", "--steps", "7"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("metrics.csv") && text(&o).contains("missing"),
        "{}",
        text(&o)
    );
    assert_eq!(text(&o).trim().lines().count(), 1, "{}", text(&o));
    assert_eq!(
        std::fs::read_to_string(dir.join("short/summary.json")).unwrap(),
        summary
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("short/config.toml")).unwrap(),
        config
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_extended_run_keeps_the_measurement_of_its_old_last_step() {
    let dir = scratch_dir("run_record", "extend_cmf");
    for args in [
        &["run", "--preset", "tiny", "--steps", "3", "--out", "run"][..],
        &["resume", "run", "--steps", "5"],
    ] {
        let o = colorvision(&dir, args);
        assert!(o.status.success(), "{args:?}: {}", text(&o));
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("run/summary.json")).unwrap())
            .unwrap();
    let steps: Vec<u64> = summary["dimension_over_steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["step"].as_u64().unwrap())
        .collect();
    assert_eq!(steps.last(), Some(&5), "{steps:?}");
    assert!(
        steps.contains(&3),
        "the old last step's measurement is gone: {steps:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn resuming_a_record_writes_nothing_into_it() {
    // A record as scripts/record-run.sh makes one: the run's small files, record.json, and the
    // last checkpoint with its parameters only. `resume` reads it as a finished run and adds
    // nothing to it (no report); extending it is refused, naming the missing per-step log.
    let dir = scratch_dir("run_record", "record_resume");
    let o = colorvision(
        &dir,
        &["train", "--preset", "tiny", "--steps", "2", "--out", "run"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let (run, rec) = (dir.join("run"), dir.join("rec"));
    let step = "checkpoints/step_00000002";
    std::fs::create_dir_all(rec.join(step)).unwrap();
    for f in ["config.toml", "run.json", "summary.json"] {
        std::fs::copy(run.join(f), rec.join(f)).unwrap();
    }
    for f in ["meta.json", "params.safetensors"] {
        std::fs::copy(run.join(step).join(f), rec.join(step).join(f)).unwrap();
    }
    std::fs::write(rec.join("record.json"), "{\"trained_in\": \"run\"}\n").unwrap();
    let before = snapshot(&rec, &[]);
    let o = colorvision(&dir, &["resume", "rec"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("finished"), "{}", text(&o));
    let o = colorvision(&dir, &["resume", "rec", "--steps", "3"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("metrics.csv"), "{}", text(&o));
    let after = snapshot(&rec, &[]);
    let names = |s: &BTreeMap<PathBuf, Vec<u8>>| s.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&after), names(&before), "files of the record");
    assert!(after == before, "a file of the record changed");
    let _ = std::fs::remove_dir_all(&dir);
}
