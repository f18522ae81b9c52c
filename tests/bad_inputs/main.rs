//! Bad input, tried as a careful tester would: every input below must stop the release binary
//! with a one-line error naming the file (or flag) and the field, exit code 1 (2 for a command
//! line clap rejects), before anything is written — no panic (101), no abort (134), and no
//! silent exit 0. The totals are printed (`cargo test --release --test bad_inputs --
//! --nocapture`).

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_colorvision");

mod cases;
mod lines;
mod scene_files;
mod settings;

use cases::{CASES, OUT_CASES};
use scene_files::write_scene_files;
use settings::RANGE_CASES;

#[derive(Debug, Default)]
struct Totals {
    tried: usize,
    clear: usize,
    unclear: Vec<String>,
    panics: Vec<String>,
    aborts: Vec<String>,
    silent: Vec<String>,
    wrote: Vec<String>,
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cv_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs one input and files the outcome.
fn try_input(dir: &Path, name: &str, args: &[String], expect: &[&str], totals: &mut Totals) {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env_remove("COLORVISION_FAULT")
        .env("XDG_CACHE_HOME", dir.join(".cache"))
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    totals.tried += 1;
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    let label = format!("{name}: {}", stderr.trim());
    use std::os::unix::process::ExitStatusExt;
    match (o.status.code(), o.status.signal()) {
        (Some(101), _) => totals.panics.push(label),
        (Some(134), _) | (None, Some(_)) => totals.aborts.push(label),
        (Some(0), _) => totals.silent.push(label),
        (Some(code), _) => {
            // One line, and a long value named rather than echoed whole.
            let one_line = (lines.len() == 1 && lines[0].chars().count() <= 400)
                || (code == 2 && lines[0].starts_with("error:"));
            let says = expect
                .iter()
                .all(|e| lines.first().is_some_and(|l| l.contains(e)));
            if one_line && says {
                totals.clear += 1;
            } else {
                totals.unclear.push(label);
            }
        }
        (None, None) => totals.aborts.push(label),
    }
}

/// An output folder that is a file, or another run's folder: refused, and left as it was.
fn try_out_cases(dir: &Path, totals: &mut Totals) {
    for (name, expect) in OUT_CASES {
        let out = dir.join("out");
        let mut args: Vec<String> = ["train", "--preset", "tiny", "--steps", "2", "--out", "out"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if name.contains("file") {
            std::fs::write(&out, "mine").unwrap();
        } else {
            std::fs::create_dir_all(&out).unwrap();
            std::fs::write(out.join("notes.txt"), "mine").unwrap();
        }
        if name.contains("force") {
            args.push("--force".into());
        }
        try_input(dir, name, &args, expect, totals);
        let intact = if out.is_file() {
            std::fs::read(&out).unwrap() == b"mine"
        } else {
            std::fs::read_dir(&out).unwrap().count() == 1
        };
        if !intact {
            totals.wrote.push(name.to_string());
        }
        let _ = std::fs::remove_file(&out);
        let _ = std::fs::remove_dir_all(&out);
    }
}

/// A 100 000-character value is named, not echoed whole (`try_input` bounds the line).
fn try_long_values(dir: &Path, totals: &mut Totals) {
    let long = format!("{}Z", "C0:400,".repeat(14_285));
    for (flag, value, names) in [
        ("--cones", long.clone(), "--cones"),
        ("--set", format!("cones={long}"), "--set"),
        ("--preset", long.clone(), "preset"),
    ] {
        let mut args: Vec<String> = ["train", "--steps", "2", "--out", "out"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        args.extend([flag.to_string(), value]);
        let name = format!("{flag} of 100 000 characters");
        try_input(dir, &name, &args, &[names], totals);
        if dir.join("out").exists() {
            totals.wrote.push(name);
            std::fs::remove_dir_all(dir.join("out")).unwrap();
        }
    }
}

/// A whole command line ([`lines::LINE_CASES`]): its error must name `expect`, and neither
/// `out` nor `runs` may be written (removed again if they were, so the next case starts clean).
fn try_line(dir: &Path, line: &[&str], expect: &[&str], totals: &mut Totals) {
    let args: Vec<String> = line.iter().map(|s| s.to_string()).collect();
    let name = line.join(" ");
    try_input(dir, &name, &args, expect, totals);
    let mut wrote = false;
    for folder in ["out", "runs"] {
        if dir.join(folder).exists() {
            wrote = true;
            std::fs::remove_dir_all(dir.join(folder)).unwrap();
        }
    }
    if wrote {
        totals.wrote.push(name);
    }
}

#[test]
fn every_bad_input_gets_a_one_line_error_naming_file_and_field_and_writes_nothing() {
    let dir = scratch("bad_inputs");
    write_scene_files(&dir);
    let mut totals = Totals::default();
    for c in CASES.iter().chain(RANGE_CASES) {
        let mut args: Vec<String> = ["train", "--preset", "tiny", "--steps", "2", "--out", "out"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if let Some(text) = c.config {
            std::fs::write(dir.join("bad.toml"), text).unwrap();
            args.extend(["--config".to_string(), "bad.toml".to_string()]);
        }
        for flag in ["--steps", "--preset"] {
            // The case's own flag replaces the default one.
            if c.args.contains(&flag) {
                let at = args.iter().position(|a| a == flag).unwrap();
                args.drain(at..at + 2);
            }
        }
        args.extend(c.args.iter().map(|s| s.to_string()));
        try_input(&dir, c.name, &args, c.expect, &mut totals);
        if dir.join("out").exists() {
            totals.wrote.push(c.name.to_string());
            std::fs::remove_dir_all(dir.join("out")).unwrap();
        }
    }
    try_out_cases(&dir, &mut totals);
    try_long_values(&dir, &mut totals);
    for (line, expect) in lines::LINE_CASES {
        try_line(&dir, line, expect, &mut totals);
    }
    println!(
        "bad inputs: {} tried, {} clear errors, {} unclear, {} panics, {} aborts, {} silent \
         (exit 0), {} wrote files",
        totals.tried,
        totals.clear,
        totals.unclear.len(),
        totals.panics.len(),
        totals.aborts.len(),
        totals.silent.len(),
        totals.wrote.len()
    );
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        totals.clear == totals.tried && totals.wrote.is_empty(),
        "{totals:#?}"
    );
}

/// Settings that were once accepted and then ignored or mislabelled are honoured.
#[test]
fn settings_once_ignored_are_honoured() {
    let dir = scratch("honoured");
    let run = |name: &str, config: &str| {
        std::fs::write(dir.join(format!("{name}.toml")), config).unwrap();
        let o = Command::new(BIN)
            .args(["train", "--config", &format!("{name}.toml"), "--out", name])
            .current_dir(&dir)
            .env_remove("COLORVISION_FAULT")
            .env("XDG_CACHE_HOME", dir.join(".cache"))
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            o.status.success(),
            "{name}: {log}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let config: toml::Value =
            toml::from_str(&std::fs::read_to_string(dir.join(name).join("config.toml")).unwrap())
                .unwrap();
        let rows = std::fs::read_to_string(dir.join(name).join("metrics.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
        (log, config, rows)
    };
    let (_, config, rows) = run(
        "train_steps",
        "preset = \"tiny\"\n[cortex.train]\nsteps = 7\n",
    );
    assert_eq!(rows, 7, "[cortex.train] steps is the run's steps");
    assert_eq!(config["steps"].as_integer(), Some(7));
    let (log, config, _) = run(
        "learned",
        "preset = \"tiny\"\nsteps = 2\n[cortex.m]\nmode = \"learned\"\n",
    );
    assert!(log.contains("optic nerve signal only"), "{log}");
    assert!(!log.contains("ORACLE"), "{log}");
    assert_eq!(config["oracle_motion"].as_bool(), Some(false));
    std::fs::remove_dir_all(&dir).ok();
}
