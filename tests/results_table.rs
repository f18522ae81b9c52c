//! The results a reader sees are generated, not typed: the README's answer to "Does it
//! reproduce the paper?", the page of the paper's rows (`docs/results.md`) and the page of every
//! run (`results/index.md`) must each be exactly what `colorvision gather results --markdown`
//! (`=rows`, `=runs`) prints from the run records in `results/` and `results/paper-rows.toml`.
//! `scripts/readme-tables.sh` writes all three.

mod common;

use common::{colorvision, text};
use std::path::Path;

/// What `colorvision gather results ARGS` prints.
fn gathered(args: &[&str]) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = vec!["gather", "results"];
    all.extend(args);
    let out = colorvision(root, &all);
    assert!(
        out.status.success(),
        "gather {args:?} failed:\n{}",
        text(&out)
    );
    String::from_utf8(out.stdout).expect("gather prints UTF-8")
}

fn read(path: &str) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(root.join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

const REGENERATE: &str = "run scripts/readme-tables.sh (after cargo build --release)";

#[test]
fn the_readme_table_is_what_gather_prints_headed_by_the_tally_in_short_rows() {
    let block = gathered(&["--markdown"]);
    assert!(
        block.starts_with("**") && block.contains(" of the paper's "),
        "the table is not headed by the tally of the paper's rows:\n{block}"
    );
    for line in block.lines().filter(|l| l.starts_with('|')) {
        let chars = line.chars().count();
        assert!(
            chars <= 120,
            "a row of {chars} characters (at most 120):\n{line}"
        );
    }
    let readme = read("README.md");
    assert!(
        readme.contains(block.trim_end()),
        "README.md does not hold what `colorvision gather results --markdown` prints; \
         {REGENERATE}:\n{block}"
    );
}

/// The README is a path a newcomer reads in order, at most 250 lines.
#[test]
fn the_readme_is_a_path_of_at_most_250_lines_in_its_order() {
    let readme = read("README.md");
    let lines = readme.lines().count();
    assert!(lines <= 250, "README.md has {lines} lines (at most 250)");
    let sections: Vec<&str> = readme
        .lines()
        .filter_map(|l| l.strip_prefix("## "))
        .collect();
    assert_eq!(
        sections,
        [
            "Two commands",
            "What you will see",
            "Does it reproduce the paper?",
            "The pipeline and the paper",
            "How to change …",
            "Benchmarks",
            "References",
        ]
    );
}

#[test]
fn the_page_of_the_rows_is_what_gather_prints_one_section_per_row_in_order() {
    let page = gathered(&["--markdown=rows"]);
    assert_eq!(
        read("docs/results.md"),
        page,
        "docs/results.md is not what `gather results --markdown=rows` prints; {REGENERATE}"
    );
    let rows: toml::Value = toml::from_str(&read("results/paper-rows.toml")).unwrap();
    let names: Vec<&str> = rows["row"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    let headings: Vec<&str> = page.lines().filter_map(|l| l.strip_prefix("## ")).collect();
    assert_eq!(
        headings, names,
        "a section per row of paper-rows.toml, in its order"
    );
    for section in page.split("\n## ").skip(1) {
        let verdict = section.lines().nth(2).unwrap_or_default();
        assert!(
            verdict.starts_with("**"),
            "the verdict comes first:\n{section}"
        );
    }
}

#[test]
fn the_page_of_every_run_is_what_gather_prints_with_no_unset_column() {
    let page = gathered(&["--markdown=runs"]);
    assert_eq!(
        read("results/index.md"),
        page,
        "results/index.md is not what `gather results --markdown=runs` prints; {REGENERATE}"
    );
    let table: Vec<&str> = page
        .lines()
        .skip_while(|l| !l.starts_with("| run |"))
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert!(table.len() > 2, "results/ holds no run record:\n{page}");
    assert!(
        !table[0].contains("| status |"),
        "a record in results/ is not a finished run (its summary.json does not read?):\n{page}"
    );
    assert!(
        !page.contains("(unset)"),
        "a column of unset settings:\n{page}"
    );
}

/// `colorvision gather results | head` must end quietly when its reader has gone: the write to
/// the closed pipe ends the process as it ends `cat`, with no panic message.
#[cfg(unix)]
#[test]
fn printing_into_a_closed_pipe_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let out = common::command(root, &["gather", "results", "--markdown"], None)
        .stdout(writer)
        .output()
        .expect("colorvision starts");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("panicked"),
        "writing into a closed pipe panicked:\n{stderr}"
    );
    assert_eq!(
        out.status.signal(),
        Some(13),
        "expected the end by SIGPIPE (13); exit {:?}, stderr:\n{stderr}",
        out.status
    );
}
