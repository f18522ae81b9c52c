//! The paper's rows judged, and the README table and the page written from them.

use super::*;
use crate::convergence::{CheckpointCmf, VerdictOverCheckpoints};
use crate::gather::{readme_table, rows_page};
use std::path::PathBuf;

/// A finished run with these settings, measured `dimension` with these margins (the rest of
/// its summary is a recorded run's).
fn run(folder: &str, cones: &str, dimension: usize, margins: &[(usize, f64)]) -> Run {
    crate::gather::recorded_run(folder, cones, "L-8k", |summary| {
        summary.dimension = dimension;
        summary.converged_ratio_per_k = margins.to_vec();
    })
}

fn rows(toml: &str) -> PaperRows {
    toml::from_str(toml).unwrap()
}

fn runs() -> Vec<Run> {
    vec![
        run("mono", "L", 1, &[(1, 0.67)]),
        run("tri", "LMS", 2, &[(1, 1.5), (2, 0.8)]),
        run("longer", "LMS", 3, &[(2, 1.2), (3, 0.7)]),
        run("custom", "L:560,X:600", 2, &[(1, 3.0), (2, 0.9)]),
    ]
}

fn path() -> PathBuf {
    PathBuf::from("results").join(ROWS_FILE)
}

const TWO_ROWS: &str = r#"
[[row]]
name = "One and three classes"
experiment = "one and three classes (§6)"
runs = ["mono", "tri"]
evidence = ["longer"]
why = "under-trained"

[[row]]
name = "Beyond"
experiment = "a fourth class at 600 nm"
runs = ["custom"]
"#;

#[test]
fn each_run_stands_beside_the_paper_and_disagreements_are_counted() {
    let table = rows(TWO_ROWS);
    let runs = runs();
    let judged = judge(&table, &runs, &path()).unwrap();
    let row = &judged[0];
    assert_eq!(
        (
            row.paper_figures(),
            row.measured_figures(),
            row.agrees_cell()
        ),
        ("1, 3".into(), "1, 2".into(), "no (1 of 2 differ)".into())
    );
    assert!(!row.reproduced() && !row.beyond_paper());
    assert!(judged[1].beyond_paper());
    assert_eq!(judged[1].agrees_cell(), "—");
    assert_eq!(
        tally(&judged),
        (1, 0, 2, 1),
        "the row beyond the paper is not counted"
    );
}

#[test]
fn the_readme_table_is_the_tally_then_one_short_row_per_experiment() {
    let table = rows(TWO_ROWS);
    let runs = runs();
    let judged = judge(&table, &runs, &path()).unwrap();
    let md = readme_table::markdown(&judged);
    assert_eq!(
        md,
        "**0 of the paper's 1 experiments reproduce in every run; 1 of their 2 runs agree with \
         the paper's figure.**\n\n\
         | experiment | paper | measured | agrees |\n|---|---|---|---|\n\
         | One and three classes | 1, 3 | 1, 2 | no (1 of 2 differ) |\n\n\
         | beyond the paper | measured |\n|---|---|\n| Beyond | 2 |\n"
    );
}

#[test]
fn the_page_of_the_rows_gives_each_verdict_first_then_runs_then_evidence() {
    let table = rows(TWO_ROWS);
    let runs = runs();
    let judged = judge(&table, &runs, &path()).unwrap();
    let page = rows_page::markdown(&judged, std::path::Path::new("results"));
    let section = page.split("\n## ").nth(1).unwrap();
    assert_eq!(
        section,
        "One and three classes\n\n**Differs in 1 of 2 runs**: the paper 1, 3; measured 1, 2.\n\n\
         one and three classes (§6).\n\n\
         - [mono](../results/mono/): **1** (K1 0.67)\n\
         - [tri](../results/tri/): **2** (K1 1.50, K2 0.80)\n\n\
         Why: under-trained\n\nEvidence:\n\n\
         - [longer](../results/longer/): **3** (K2 1.20, K3 0.70)\n"
    );
    assert!(
        page.contains("\n## Beyond\n\n**Beyond the paper**: measured 2.\n"),
        "{page}"
    );
}

#[test]
fn checkpoints_measured_on_the_way_are_read_beside_the_final_figure() {
    let mut border = run("border", "LMS", 3, &[(2, 1.2), (3, 0.96)]);
    let at = |step, dimension, margin| CheckpointCmf {
        step,
        dimension,
        per_k: vec![[dimension as f64, 1.0, margin]],
    };
    border.over_checkpoints = VerdictOverCheckpoints::from_points(vec![
        at(34_000, 3, 0.87),
        at(38_000, 4, 0.80),
        at(40_000, 3, 0.96),
    ]);
    let text = rows_page::measured(&border, "../results");
    assert_eq!(
        text,
        "[border](../results/border/): **3** (K2 1.20, K3 0.96) — 3, 4, 3 at 34 000–40 000 \
         steps: on the border"
    );
    // The averaged weights' figure follows, read from a record.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    let file = crate::averaging::averaged_path(&root.join("LMSQ-humanQ-idealised-48k"));
    border.averaged = Some(crate::averaging::Averaged::read(&file).unwrap());
    assert!(
        rows_page::measured(&border, "../results").ends_with(
            "on the border; weights averaged over 8 checkpoints, 34 000–48 000 steps: **3** \
             (K1 20.06, K2 1.36, K3 0.91)"
        ),
        "{}",
        rows_page::measured(&border, "../results")
    );
}

#[test]
fn a_row_that_differs_from_the_paper_must_say_why() {
    let runs = runs();
    let table = rows("[[row]]\nname = \"x\"\nexperiment = \"x\"\nruns = [\"tri\"]\n");
    let err = judge(&table, &runs, &path()).unwrap_err().to_string();
    assert!(
        err.contains(ROWS_FILE) && err.contains("row `x`: why"),
        "{err}"
    );
    // A row that agrees needs no words.
    let table = rows("[[row]]\nname = \"x\"\nexperiment = \"x\"\nruns = [\"mono\", \"longer\"]\n");
    let judged = judge(&table, &runs, &path()).unwrap();
    assert!(judged[0].reproduced());
    assert_eq!(judged[0].agrees_cell(), "yes");
}

#[test]
fn a_run_not_gathered_is_an_error_naming_the_row_and_field() {
    for field in ["runs", "evidence"] {
        let text =
            format!("[[row]]\nname = \"x\"\nexperiment = \"x\"\nruns = []\n{field} = [\"gone\"]\n");
        let text = text.replacen("runs = []\nruns", "runs", 1);
        let err = judge(&rows(&text), &runs(), &path())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(&format!("row `x`: {field}")) && err.contains("`gone`"),
            "{err}"
        );
    }
}

#[test]
fn the_rows_file_is_optional_and_a_wrong_or_missing_field_is_named() {
    let dir = std::env::temp_dir().join(format!("cv_paper_rows_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    assert!(read(&dir).unwrap().is_none());
    let file = dir.join(ROWS_FILE);
    std::fs::write(
        &file,
        "[[row]]\nname = \"x\"\nexperiment = \"x\"\nrun = []\n",
    )
    .unwrap();
    let err = read(&dir).unwrap_err().to_string();
    assert!(err.contains(ROWS_FILE) && err.contains("run"), "{err}");
    std::fs::write(&file, "[[row]]\nexperiment = \"x\"\nruns = []\n").unwrap();
    let err = read(&dir).unwrap_err().to_string();
    assert!(err.contains(ROWS_FILE) && err.contains("name"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
