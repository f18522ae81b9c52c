//! Forward-forward's `rule.objective` end to end: chosen in a config file, it reaches the trainer
//! (the two objectives train differently from the same start), every step's loss stays finite,
//! the run records the setting, and a value it does not have is refused naming the file, the
//! value and the values it has.

mod common;

use colorvision::run::{run, RunMode};
use std::path::Path;

fn config(objective: &str) -> String {
    format!(
        "preset = \"tiny\"\nsteps = 6\nlearning_rule = \"forward-forward\"\n\
         [rule]\nobjective = \"{objective}\"\n[cortex.train]\nalignment_every_steps = 3\n"
    )
}

/// The training loss of every step of the run in `dir` (`metrics.csv`, column `loss`).
fn losses(dir: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "loss")
        .expect("a loss column");
    lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect()
}

/// Trains the tiny run of `objective` in `dir/objective`; its losses.
fn trained(dir: &Path, objective: &str) -> Vec<f64> {
    let path = dir.join(format!("{objective}.toml"));
    std::fs::write(&path, config(objective)).unwrap();
    let config = common::resolve_config_file(&path).unwrap();
    let mode = RunMode {
        cmf_sim: false,
        pictures: false,
        progress: false,
    };
    let out = dir.join(objective);
    assert_eq!(run(&config, &out, mode).unwrap().steps, 6);
    let recorded = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        recorded.contains(&format!("objective = \"{objective}\"")),
        "{objective} not recorded in config.toml"
    );
    losses(&out)
}

#[test]
fn the_objective_setting_reaches_the_trainer_and_is_recorded() {
    let dir = common::scratch_dir("ff_setting", "objectives");
    let goodness = trained(&dir, "goodness");
    let prediction = trained(&dir, "prediction");
    assert_eq!(goodness.len(), 6);
    assert_eq!(prediction.len(), 6);
    assert!(
        goodness.iter().chain(&prediction).all(|l| l.is_finite()),
        "{goodness:?} {prediction:?}"
    );
    // The same seed and first batch: the first step's prediction loss is the same cortex's; the
    // updates differ by objective, so the later losses do.
    assert_eq!(goodness[0], prediction[0]);
    assert!(
        goodness[1..]
            .iter()
            .zip(&prediction[1..])
            .any(|(g, p)| g != p),
        "{goodness:?} {prediction:?}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn an_objective_forward_forward_does_not_have_is_refused_naming_it() {
    let dir = common::scratch_dir("ff_setting", "bad");
    let path = dir.join("rule.toml");
    std::fs::write(&path, config("predict")).unwrap();
    let e = common::resolve_config_file(&path).unwrap_err();
    assert!(
        e.contains("rule.toml") && e.contains("`predict`") && e.contains("`prediction`"),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}
