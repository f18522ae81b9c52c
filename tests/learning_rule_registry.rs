//! A learning rule from outside the library — `examples/noisy_feedback/rule.rs`, one file —
//! registered by one call is selectable from `--config`, sweeps by name, trains the cortex and
//! is measured against backprop; the stock binary, which did not register it, refuses it by
//! name. The example binary (`cargo build --examples`; `cargo test` builds it) runs it end to
//! end.

mod common;

#[path = "../examples/noisy_feedback/rule.rs"]
mod rule;

use colorvision::run::{run, RunMode};
use std::path::Path;
use std::sync::Once;

fn registered() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| cortex::rule::register(rule::entry()).unwrap());
}

const CONFIG: &str = "preset = \"tiny\"\nsteps = 4\nlearning_rule = \"noisy-feedback\"\n\
[rule]\nnoise = 0.5\n[cortex.train]\nalignment_every_steps = 2\n";

#[test]
fn a_registered_rule_is_selected_from_a_config_file_and_trains() {
    registered();
    let dir = common::scratch_dir("rule_registry", "config");
    let path = dir.join("rule.toml");
    std::fs::write(&path, CONFIG).unwrap();
    let config = common::resolve_config_file(&path).unwrap();
    assert_eq!(config.learning_rule.as_str(), "noisy-feedback");
    std::fs::write(&path, CONFIG.replace("noise =", "nois =")).unwrap();
    let e = common::resolve_config_file(&path).unwrap_err();
    assert!(e.contains("rule.toml") && e.contains("nois"), "{e}");

    let mode = RunMode {
        cmf_sim: false,
        pictures: false,
        progress: false,
    };
    let summary = run(&config, &dir.join("run"), mode).unwrap();
    assert_eq!(summary.steps, 4);
    let rows = colorvision::alignment_plot::cosines(&dir.join("run").join("metrics.csv"));
    assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), [2, 4]);
    let d = rows[1].1[2].unwrap();
    assert!(d < 0.9999 && d > -1.0, "D's cosine to backprop {d}");
    let text = std::fs::read_to_string(dir.join("run").join("config.toml")).unwrap();
    assert!(text.contains("learning_rule = \"noisy-feedback\"") && text.contains("noise = 0.5"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_registered_rule_sweeps_by_name() {
    registered();
    let dir = common::scratch_dir("rule_registry", "sweep");
    let spec = dir.join("spec.toml");
    std::fs::write(
        &spec,
        "[base]\npreset = \"tiny\"\nsteps = 2\n[grid]\n\
         learning_rule = [\"backprop\", \"noisy-feedback\"]\nseed = [0, 1]\n",
    )
    .unwrap();
    let expanded = colorvision::sweep::spec::expand(&spec).unwrap();
    let rules: Vec<&str> = (expanded.jobs.iter())
        .map(|j| j.config.learning_rule.as_str())
        .collect();
    assert_eq!(
        rules,
        ["backprop", "backprop", "noisy-feedback", "noisy-feedback"]
    );
    std::fs::write(
        &spec,
        "[base]\npreset = \"tiny\"\nlearning_rule = \"noisy-feedback\"\n[grid]\n\
         \"rule.noise\" = [0.0, 2.0]\n",
    )
    .unwrap();
    let expanded = colorvision::sweep::spec::expand(&spec).unwrap();
    assert_eq!(expanded.jobs.len(), 2);
    assert_eq!(expanded.jobs[1].config.rule["noise"], 2.0);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_example_binary_runs_its_rule_and_the_stock_binary_refuses_it_by_name() {
    let dir = common::scratch_dir("rule_registry", "binary");
    std::fs::write(dir.join("rule.toml"), CONFIG).unwrap();
    let stock = common::colorvision(&dir, &["train", "--config", "rule.toml", "--out", "x"]);
    let said = common::text(&stock);
    assert!(!stock.status.success());
    assert!(said.contains("rule.toml") && said.contains("unknown rule \"noisy-feedback\""));
    assert!(
        said.contains("kolen-pollack"),
        "the registered rules are listed: {said}"
    );

    let bin = Path::new(common::BIN)
        .with_file_name("examples")
        .join("noisy_feedback");
    assert!(
        bin.exists(),
        "{} is not built: `cargo build --release --examples` (cargo test builds it)",
        bin.display()
    );
    let o = std::process::Command::new(&bin)
        .args(["train", "--config", "rule.toml", "--out", "run"])
        .current_dir(&dir)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    let said = common::text(&o);
    assert!(o.status.success(), "{said}");
    assert!(said.contains("learning rule: noisy-feedback"), "{said}");
    assert!(dir.join("run").join("alignment.svg").exists());
    std::fs::remove_dir_all(dir).ok();
}
