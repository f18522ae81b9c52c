//! `run`/`train --continue-from PATH`: a cortex trained on one eye goes on learning on another
//! (gene therapy, dimensionality boosting) from a run folder or a checkpoint folder; the step
//! count continues, the run records where it started, and a start that cannot work (no
//! checkpoint there, a cortex of another shape) stops before the output folder exists.
//! `gather` shows where each continued run came from.

mod common;

use common::{colorvision, text};
use std::path::Path;

fn continued_from(run: &Path) -> String {
    let marker = std::fs::read_to_string(run.join("run.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&marker).unwrap();
    v["continued_from"].as_str().unwrap_or_default().to_string()
}

/// `colorvision ARGS` in `dir`, which must succeed; what it printed.
fn ok(dir: &Path, args: &[&str]) -> String {
    let o = colorvision(dir, args);
    assert!(o.status.success(), "{args:?}: {}", text(&o));
    text(&o)
}

/// `train --preset tiny` of `cones` for `steps` into `out`, from the cortex at `from`.
fn train_tiny(dir: &Path, cones: &str, steps: &str, out: &str, from: Option<&str>) -> String {
    let mut args = vec![
        "train", "--preset", "tiny", "--cones", cones, "--steps", steps, "--out", out,
    ];
    args.extend(from.map(|f| ["--continue-from", f]).into_iter().flatten());
    ok(dir, &args)
}

/// `colorvision ARGS` in `dir` must fail, naming each of `names`, and leave no `out`.
fn refused(dir: &Path, args: &[&str], out: &str, names: &[&str]) {
    let o = colorvision(dir, args);
    assert!(!o.status.success(), "{args:?} ran");
    for n in names {
        assert!(text(&o).contains(n), "{args:?}: `{n}` not in {}", text(&o));
    }
    assert!(!dir.join(out).exists(), "{args:?} wrote {out}");
}

/// A record of a run (its small files copied elsewhere, as `scripts/record-run.sh` does)
/// names the folder it was trained in; gather then names a run continued from that folder by
/// the record's row, not by the training folder's name. A therapy eye trained from scratch
/// joins them, so that `continued_from` is not redundant with `cones` (gather drops a column
/// that splits the runs as another does).
fn a_record_names_the_run_a_cortex_continued_from(dir: &Path) {
    train_tiny(dir, "MS+L_replace_M", "1", "fresh", None);
    let records = dir.join("records");
    for (run, record) in [
        ("ms", "MS-3"),
        ("therapy", "therapy-2"),
        ("fresh", "fresh-1"),
    ] {
        std::fs::create_dir_all(records.join(record)).unwrap();
        for file in ["config.toml", "run.json"] {
            std::fs::copy(dir.join(run).join(file), records.join(record).join(file)).unwrap();
        }
    }
    // A run names its start from its own folder; a record, as scripts/record-run.sh writes
    // it, from the folder gather runs in.
    assert_eq!(
        continued_from(&dir.join("therapy")),
        "../ms/checkpoints/step_00000003"
    );
    let marker = records.join("therapy-2/run.json");
    let as_run = std::fs::read_to_string(&marker).unwrap();
    let from_root = as_run.replace("../ms/checkpoints", "ms/checkpoints");
    assert_ne!(as_run, from_root);
    std::fs::write(&marker, from_root).unwrap();
    let gathered = || {
        text(&colorvision(
            dir,
            &["gather", records.to_str().unwrap(), "--markdown"],
        ))
    };
    let table = gathered();
    assert!(table.contains("| ms @ 3 |"), "{table}");
    std::fs::write(
        records.join("MS-3/record.json"),
        serde_json::json!({ "trained_in": dir.join("ms") }).to_string(),
    )
    .unwrap();
    let table = gathered();
    assert!(table.contains("| MS-3 @ 3 |"), "{table}");
}

#[test]
fn a_cortex_continues_on_another_eye_from_a_run_or_a_checkpoint() {
    let dir = std::env::temp_dir().join(format!("cv_continue_from_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    train_tiny(&dir, "MS", "3", "ms", None);
    let said = train_tiny(&dir, "MS+L_replace_M", "2", "therapy", Some("ms"));
    assert!(said.contains("continuing the cortex of"), "{said}");
    // From the run folder: its newest checkpoint; the step count goes on from 3.
    assert!(continued_from(&dir.join("therapy")).ends_with("ms/checkpoints/step_00000003"));
    assert!(dir
        .join("therapy/checkpoints/step_00000005/meta.json")
        .is_file());
    // From a checkpoint folder named directly.
    let checkpoint = Some("therapy/checkpoints/step_00000005");
    train_tiny(&dir, "LMSQ", "1", "boost", checkpoint);
    assert!(continued_from(&dir.join("boost")).ends_with("therapy/checkpoints/step_00000005"));
    assert!(dir
        .join("boost/checkpoints/step_00000006/meta.json")
        .is_file());
    a_record_names_the_run_a_cortex_continued_from(&dir);

    let tiny = ["train", "--preset", "tiny", "--steps", "1", "--out", "none"];
    let nowhere = [&tiny[..], &["--continue-from", "nowhere"]].concat();
    refused(&dir, &nowhere, "none", &["nowhere", "--continue-from"]);
    // The quick cortex's W is 127×127, the tiny checkpoint's 63×63.
    let quick = [
        "train",
        "--preset",
        "quick",
        "--cones",
        "MS",
        "--steps",
        "1",
        "--out",
        "misfit",
        "--continue-from",
        "ms",
    ];
    refused(&dir, &quick, "misfit", &["params.safetensors", "shape"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
