//! The gathered table of colour-matching functions against Stiles & Burch (1955): one row per
//! run whose folder holds `stiles-burch/table.json` (written by `colorvision stiles-burch --run
//! DIR`, [`crate::stiles_burch`]), with the trained cortex's Pearson r per channel (r̄, ḡ, b̄),
//! the ceiling set by the eye's own cone fundamentals, and the cortex's r as a fraction of that
//! ceiling. Runs without the file get no row; the table is empty when none has one.

use super::Run;
use crate::stiles_burch::Row;
use std::path::Path;

/// Where a run folder keeps its Stiles & Burch comparison.
pub const TABLE_FILE: &str = "stiles-burch/table.json";

/// The comparison of the run in `dir`: `None` when it has none, an error text when the file
/// does not read.
pub fn read(dir: &Path) -> Option<Result<Vec<Row>, String>> {
    let path = dir.join(TABLE_FILE);
    if !path.is_file() {
        return None;
    }
    let text = std::fs::read_to_string(&path).map_err(|e| e.to_string());
    Some(text.and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string())))
}

fn correlation(rows: &[Row], observer: &str) -> Option<[f64; 3]> {
    rows.iter()
        .find(|r| r.observer == observer)
        .map(|r| r.correlation)
}

fn triple(x: [f64; 3], digits: usize) -> String {
    x.map(|v| format!("{v:.digits$}")).join(" / ")
}

/// The Markdown table (empty text when no run has a comparison with a trained cortex).
pub fn markdown(runs: &[Run]) -> String {
    let mut out = String::new();
    for run in runs {
        let Some(rows) = &run.stiles_burch else {
            continue;
        };
        let Some(trained) = correlation(rows, "trained") else {
            continue;
        };
        let ceiling = correlation(rows, "own_fundamentals");
        let of_ceiling = ceiling.map_or("—".into(), |c| {
            triple(std::array::from_fn(|i| trained[i] / c[i]), 2)
        });
        let dimension = run
            .summary
            .as_ref()
            .map_or(String::new(), |s| s.dimension.to_string());
        out.push_str(&format!(
            "| {} | {} | {dimension} | {} | {} | {of_ceiling} |\n",
            run.folder,
            run.steps.map_or(String::new(), |s| s.to_string()),
            triple(trained, 3),
            ceiling.map_or("—".into(), |c| triple(c, 3)),
        ));
    }
    if out.is_empty() {
        return out;
    }
    // Printed lines of at most 100 columns (each ends in `\n`): the README holds them as printed.
    let caption = "Colour-matching functions with the primaries of Stiles & Burch (1955), \
                   645.2 / 526.3 / 444.4 nm,\n\
                   against theirs (`colorvision stiles-burch --run DIR`): Pearson r of \
                   r̄ / ḡ / b̄, beside the ceiling\n\
                   any cortex on this eye's cones can reach.\n\n";
    let head = "| run | steps done | CMF-SIM | r̄ / ḡ / b̄ r | ceiling (own fundamentals) | \
                of the ceiling |\n|---|---|---|---|---|---|\n";
    format!("{caption}{head}{out}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gather::Status;

    fn row(observer: &str, r: [f64; 3]) -> Row {
        Row {
            observer: observer.into(),
            correlation: r,
            rmse: [0.1; 3],
        }
    }

    fn run(folder: &str, stiles_burch: Option<Vec<Row>>) -> Run {
        Run {
            folder: folder.into(),
            status: Status::Pending,
            steps: Some(40000),
            summary: None,
            settings: Default::default(),
            stiles_burch,
            over_checkpoints: None,
            other_location_seeds: Vec::new(),
            averaged: None,
        }
    }

    #[test]
    fn a_run_with_a_comparison_gets_a_row_with_its_fraction_of_the_ceiling() {
        let rows = vec![
            row("own_fundamentals", [0.8, 0.5, 1.0]),
            row("trained", [0.6, 0.5, 0.9]),
        ];
        let md = markdown(&[run("a", Some(rows)), run("b", None)]);
        assert!(
            md.contains("| a | 40000 |  | 0.600 / 0.500 / 0.900 | 0.800 / 0.500 / 1.000 | 0.75 / 1.00 / 0.90 |"),
            "{md}"
        );
        assert!(!md.contains("| b |"), "{md}");
        assert_eq!(md.lines().filter(|l| l.starts_with('|')).count(), 3, "{md}");
    }

    #[test]
    fn no_comparison_no_table() {
        assert_eq!(markdown(&[run("a", None)]), "");
        let only_ceiling = vec![row("own_fundamentals", [0.8; 3])];
        assert_eq!(markdown(&[run("a", Some(only_ceiling))]), "");
    }

    #[test]
    fn the_table_file_reads_back_what_stiles_burch_writes() {
        let dir = std::env::temp_dir().join(format!("cv_gather_sb_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        assert!(read(&dir).is_none());
        std::fs::create_dir(dir.join("stiles-burch")).unwrap();
        let rows = vec![row("trained", [0.9, 0.8, 0.7])];
        crate::io::write_json(&dir.join(TABLE_FILE), &rows).unwrap();
        assert_eq!(read(&dir).unwrap().unwrap(), rows);
        std::fs::write(dir.join(TABLE_FILE), "[{").unwrap();
        assert!(read(&dir).unwrap().is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
