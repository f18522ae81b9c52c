//! Sweeps as a user runs them: a spec expands to run folders and a Slurm job array; the array's
//! script runs the task `SLURM_ARRAY_TASK_ID` names (here, without Slurm), skipping a finished
//! run and resuming an interrupted one; `sweep --local` runs every task and, stopped, starts no
//! further one; `gather` tabulates
//! done, failed, stopped, pending and unreadable runs.

mod common;

use common::text;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cv_sweep_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn colorvision(dir: &Path, args: &[&str]) -> Output {
    common::command(dir, args, None)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .expect("the binary runs")
}

/// `bash DIR/sweep.sbatch` as a Slurm array task `task` would run it.
fn array_task(sweep: &Path, task: Option<usize>, fault: Option<&str>) -> Output {
    let mut c = Command::new("bash");
    // The script runs the binary that wrote it (this one) unless COLORVISION says otherwise.
    c.arg(sweep.join("sweep.sbatch"))
        .env_remove("COLORVISION")
        .env("RAYON_NUM_THREADS", "1")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("COLORVISION_FAULT");
    if let Some(t) = task {
        c.env("SLURM_ARRAY_TASK_ID", t.to_string());
    }
    if let Some(f) = fault {
        c.env("COLORVISION_FAULT", f);
    }
    c.output().expect("bash runs")
}

/// Writes `spec.toml` with `grid` in `dir` and expands it into `dir/sw`.
fn expand(dir: &Path, grid: &str) -> PathBuf {
    let spec =
        format!("[base]\npreset = \"tiny\"\nsteps = 12\n[grid]\n{grid}[slurm]\nconcurrency = 2\n");
    std::fs::write(dir.join("spec.toml"), spec).unwrap();
    let o = colorvision(dir, &["sweep", "spec.toml", "--out", "sw"]);
    assert!(o.status.success(), "{}", text(&o));
    dir.join("sw")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn folders(sweep: &Path) -> Vec<String> {
    let m = json(&sweep.join("sweep.json"));
    m["tasks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["folder"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn a_spec_expands_to_run_folders_and_array_tasks() {
    let dir = scratch("expand");
    let sw = expand(&dir, "cones = [\"LMS\", \"LM\"]\nseed = [0, 1]\n");
    let names = folders(&sw);
    assert_eq!(
        names,
        [
            "000_cones=LMS_seed=0",
            "001_cones=LMS_seed=1",
            "002_cones=LM_seed=0",
            "003_cones=LM_seed=1"
        ]
    );
    for (i, name) in names.iter().enumerate() {
        let config: toml::Value =
            toml::from_str(&std::fs::read_to_string(sw.join(name).join("config.toml")).unwrap())
                .unwrap();
        let want_cones = if i < 2 { "LMS" } else { "LM" };
        assert_eq!(config["cones"].as_str(), Some(want_cones), "{name}");
        assert_eq!(config["seed"].as_integer(), Some(i as i64 % 2), "{name}");
        assert_eq!(config["steps"].as_integer(), Some(12), "{name}");
        assert!(sw.join(name).join("run.json").is_file());
    }
    // Slurm opens the tasks' logs there before any task runs.
    assert!(sw.join("logs").is_dir());
    let script = std::fs::read_to_string(sw.join("sweep.sbatch")).unwrap();
    for want in [
        "#SBATCH --array=0-3%2\n",
        "#SBATCH --cpus-per-task=1\n",
        "#SBATCH --requeue\n",
    ] {
        assert!(script.contains(want), "{want} not in\n{script}");
    }
    // A second expansion into the same folder, and a bad spec, write nothing.
    let o = colorvision(&dir, &["sweep", "spec.toml", "--out", "sw"]);
    assert!(
        !o.status.success() && text(&o).contains("not an empty folder"),
        "{}",
        text(&o)
    );
    std::fs::write(
        dir.join("bad.toml"),
        "[grid]\nseed = [0]\ncones = [\"LMX\"]\n",
    )
    .unwrap();
    let o = colorvision(&dir, &["sweep", "bad.toml", "--out", "bad"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(
        t.contains("bad.toml") && t.contains("cones = \"LMX\""),
        "{t}"
    );
    assert!(!dir.join("bad").exists());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_array_script_runs_its_task_resumes_and_skips() {
    let dir = scratch("script");
    let sw = expand(&dir, "seed = [0, 1, 2]\n");
    let names = folders(&sw);
    let o = array_task(&sw, None, None);
    assert!(
        !o.status.success() && text(&o).contains("SLURM_ARRAY_TASK_ID"),
        "{}",
        text(&o)
    );
    // Task 1, stopped at step 6 as by SIGTERM (Slurm's preemption or time limit).
    let o = array_task(&sw, Some(1), Some("interrupt@step:6"));
    assert_eq!(o.status.code(), Some(130), "{}", text(&o));
    let run1 = sw.join(&names[1]);
    assert!(run1.join("checkpoints/step_00000006").is_dir());
    assert!(!run1.join("summary.json").exists());
    for other in [&names[0], &names[2]] {
        assert!(
            !sw.join(other).join("checkpoints").exists(),
            "{other} was run"
        );
    }
    // The local runner runs every task through the same script: task 1 continues at step 6.
    let o = colorvision(&dir, &["sweep", "--local", "-j", "2", "sw"]);
    assert!(o.status.success(), "{}", text(&o));
    for name in &names {
        let s = json(&sw.join(name).join("summary.json"));
        assert_eq!(s["steps"], 12, "{name}");
    }
    // Each finished run has its page, self-contained: pictures and plots embedded.
    let page = std::fs::read_to_string(run1.join("report.html")).unwrap();
    assert!(page.starts_with("<!DOCTYPE html>") && page.ends_with("</html>\n"));
    assert_eq!(
        page.matches("data:image/png;base64,").count(),
        6, // scope, own_S (the last class's own signal), learned C, true mosaic, W, ONS
        "PNG pictures"
    );
    assert_eq!(
        page.matches("data:image/svg+xml;base64,").count(),
        4,
        "SVG plots"
    );
    assert!(
        !page.contains("<script") && !page.contains("src=\"http"),
        "nothing fetched"
    );
    let s1 = json(&run1.join("summary.json"));
    assert_eq!(s1["resumed_at_steps"], serde_json::json!([6]));
    assert!(std::fs::read_to_string(sw.join("logs/task-0.log"))
        .unwrap()
        .contains("sweep task 0"));
    // A task whose run finished is skipped and leaves the run as it was.
    let before = std::fs::read(run1.join("summary.json")).unwrap();
    let o = array_task(&sw, Some(1), None);
    assert!(
        o.status.success() && text(&o).contains("finished"),
        "{}",
        text(&o)
    );
    assert_eq!(std::fs::read(run1.join("summary.json")).unwrap(), before);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_local_sweep_stopped_like_ctrl_c_starts_no_further_task_and_continues() {
    let dir = scratch("local_stop");
    let sw = expand(&dir, "seed = [0, 1, 2]\n");
    let names = folders(&sw);
    // Every task would stop at step 6 as by Ctrl-C: the first does, and no other starts.
    let o = common::command(
        &dir,
        &["sweep", "--local", "-j", "1", "sw"],
        Some("interrupt@step:6"),
    )
    .env("RAYON_NUM_THREADS", "1")
    .output()
    .expect("the binary runs");
    assert!(!o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("1 (not started), 2 (not started)"),
        "{}",
        text(&o)
    );
    assert!(sw
        .join(&names[0])
        .join("checkpoints/step_00000006")
        .is_dir());
    for other in &names[1..] {
        assert!(
            !sw.join(other).join("checkpoints").exists(),
            "{other} was started after the stop"
        );
    }
    // The same command continues: every run finishes.
    let o = colorvision(&dir, &["sweep", "--local", "-j", "1", "sw"]);
    assert!(o.status.success(), "{}", text(&o));
    for name in &names {
        assert_eq!(
            json(&sw.join(name).join("summary.json"))["steps"],
            12,
            "{name}"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn gather_tabulates_done_failed_stopped_pending_and_unreadable_runs() {
    let dir = scratch("gather");
    let sw = expand(&dir, "seed = [0, 1, 2, 3]\n");
    let names = folders(&sw);
    assert!(array_task(&sw, Some(0), None).status.success());
    // Task 1's settings are edited into an invalid value: the task fails and says why.
    let c1 = sw.join(&names[1]).join("config.toml");
    let edited = std::fs::read_to_string(&c1)
        .unwrap()
        .replacen("steps = 12", "steps = 0", 1);
    std::fs::write(&c1, edited).unwrap();
    assert_eq!(array_task(&sw, Some(1), None).status.code(), Some(1));
    assert_eq!(
        array_task(&sw, Some(2), Some("interrupt@step:6"))
            .status
            .code(),
        Some(130)
    );
    // A run folder whose summary.json does not read.
    let broken = sw.join("extra/broken");
    std::fs::create_dir_all(&broken).unwrap();
    std::fs::copy(
        sw.join(&names[0]).join("config.toml"),
        broken.join("config.toml"),
    )
    .unwrap();
    std::fs::write(broken.join("summary.json"), "{\"dimension\": ").unwrap();

    let o = colorvision(&dir, &["gather", "sw"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("extra/broken/summary.json"),
        "{t}"
    );
    let md = std::fs::read_to_string(sw.join("gather.md")).unwrap();
    let row = |name: &str| {
        md.lines()
            .find(|l| l.starts_with(&format!("| {name} |")))
            .unwrap_or_else(|| panic!("no row {name} in\n{md}"))
            .to_string()
    };
    // Task 1's edited step count sets it apart from the grid: it gets a column.
    assert!(
        md.lines()
            .next()
            .unwrap()
            .starts_with("| run | seed | steps | status | steps done |"),
        "{md}"
    );
    assert!(
        row(&names[1]).starts_with(&format!("| {} | 1 | 0 |", names[1])),
        "{md}"
    );
    assert!(
        row(&names[0]).contains("| done | 12 |") && row(&names[0]).contains("**"),
        "{md}"
    );
    assert!(
        row(&names[1]).contains("| failed: ") && row(&names[1]).contains("steps"),
        "{md}"
    );
    assert!(row(&names[2]).contains("| stopped | 6 |"), "{md}");
    assert!(row(&names[3]).contains("| pending |"), "{md}");
    assert!(row("extra/broken").contains("| unreadable: "), "{md}");
    let csv = std::fs::read_to_string(sw.join("gather.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let done: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    assert_eq!(done[col("status")], "done", "{csv}");
    let gain: f64 = done[col("heldout_gain")].parse().unwrap();
    let margin: f64 = done[col("margin_k1")].parse().unwrap();
    assert!(gain > 0.0 && margin > 0.0, "{csv}");
    // index.html links the finished run to its report and shows its dimension over training;
    // runs without a report are listed unlinked.
    let index = std::fs::read_to_string(sw.join("index.html")).unwrap();
    assert!(
        index.contains(&format!("<a href=\"{}/report.html\">", names[0])),
        "{index}"
    );
    assert_eq!(index.matches("<a href=").count(), 1, "{index}");
    assert_eq!(index.matches("data:image/svg+xml;base64,").count(), 1);
    assert!(
        index.contains("<b>") && index.contains(&names[3]),
        "{index}"
    );
    // --markdown prints the same table and writes nothing.
    std::fs::remove_file(sw.join("gather.md")).unwrap();
    let o = colorvision(&dir, &["gather", "sw", "--markdown"]);
    assert_eq!(String::from_utf8_lossy(&o.stdout), md);
    assert!(!sw.join("gather.md").exists());
    std::fs::remove_dir_all(dir).ok();
}
