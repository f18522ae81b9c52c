//! The README's table of recorded runs is generated, not typed: it must be exactly what
//! `colorvision gather results --markdown` prints from the run records in `results/`, the
//! paper's rows (`results/paper-rows.toml`) first.

mod common;

use common::{colorvision, text};
use std::path::Path;

#[test]
fn the_readme_table_of_recorded_runs_is_what_gather_prints_from_results() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = colorvision(root, &["gather", "results", "--markdown"]);
    assert!(
        out.status.success(),
        "gather results failed:\n{}",
        text(&out)
    );
    let table = String::from_utf8(out.stdout).expect("gather prints UTF-8");
    // The paper's rows (results/paper-rows.toml) come first, then the runs' table; a table of
    // CMFs against Stiles & Burch and one of the dichromats' hue axes may follow it.
    assert!(
        table.starts_with("| the paper's experiment |"),
        "results/ lists the paper's rows, but gather printed no table of them first:\n{table}"
    );
    let rows: Vec<&str> = table
        .lines()
        .skip_while(|l| !l.starts_with("| run |"))
        .skip(2)
        .take_while(|l| !l.is_empty())
        .collect();
    assert!(!rows.is_empty(), "results/ holds no run record:\n{table}");
    for row in &rows {
        assert!(
            row.contains("| done |"),
            "a record in results/ is not a finished run (its summary.json does not read?):\n{row}"
        );
    }
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md reads");
    assert!(
        readme.contains(table.trim_end()),
        "README.md does not hold the table `colorvision gather results --markdown` prints; \
         paste it in:\n{table}"
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
