//! Several runs' convergence side by side — typically the same eye trained from several seeds
//! (`colorvision convergence --run A --run B --run C --out DIR`).
//!
//! Each run is first studied on its own ([`super::study`], into its own `convergence/`); then
//! `DIR` gets one plot per measure with a line per run — held-out prediction gain, C's worst
//! per-class recall (nearest class centre), W's surround r, P's position error (cone spacings
//! RMS) and CMF-SIM's dimension where it was measured — and `runs.md`, every measured step of
//! every run in one table.

use super::report::min_of;
use super::StudyRow;
use crate::io::write_atomic;
use crate::run::error::RunError;
use colorimetry::plot::{LinePlot, Series};
use std::fmt::Write as _;
use std::path::Path;

/// One colour per run (Okabe–Ito, colour-blind safe), repeated past eight runs.
const RUN_COLOURS: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000",
];

/// A measure read off one checkpoint: its column in `runs.md` (with its decimals) and its plot.
struct Measure {
    column: &'static str,
    digits: usize,
    file: &'static str,
    title: &'static str,
    y_label: &'static str,
    log_y: bool,
    value: fn(&StudyRow) -> Option<f64>,
}

const MEASURES: [Measure; 5] = [
    Measure {
        column: "gain",
        digits: 1,
        file: "runs_gain.svg",
        title: "Held-out prediction error of \"next = current\" over the cortex's",
        y_label: "gain (×)",
        log_y: true,
        value: |r| r.heldout_gain,
    },
    Measure {
        column: "C worst recall",
        digits: 2,
        file: "runs_c_recall.svg",
        title: "C: worst per-class recall by nearest class centre (1 = recovered)",
        y_label: "recall",
        log_y: false,
        value: |r| {
            r.recovery
                .c
                .as_ref()
                .map(|c| min_of(&c.recall_nearest_centroid))
        },
    },
    Measure {
        column: "W surround r",
        digits: 2,
        file: "runs_w_surround.svg",
        title: "W: surround r against the eye's DoG (1 = recovered)",
        y_label: "r",
        log_y: false,
        value: |r| r.recovery.w.as_ref().map(|w| w.surround_r),
    },
    Measure {
        column: "P error",
        digits: 2,
        file: "runs_p_error.svg",
        title: "P: position error after the affine gauge",
        y_label: "cone spacings RMS",
        log_y: true,
        value: |r| Some(r.recovery.p.position_error_rms_cones),
    },
    Measure {
        column: "CMF-SIM",
        digits: 0,
        file: "runs_dimension.svg",
        title: "CMF-SIM: colour dimensionality where measured",
        y_label: "dimension",
        log_y: false,
        value: |r| r.cmf.as_ref().map(|c| c.dimension as f64),
    },
];

/// Writes the plots and `runs.md` of `runs` (label, rows in step order) into `out`.
pub fn write(out: &Path, runs: &[(String, Vec<StudyRow>)]) -> Result<(), RunError> {
    std::fs::create_dir_all(out).map_err(crate::io::fs_err(out))?;
    for m in &MEASURES {
        let mut plot = LinePlot::new(m.title, "step", m.y_label);
        (plot.x.log, plot.y.log) = (true, m.log_y);
        for (i, (label, rows)) in runs.iter().enumerate() {
            let (xs, ys): (Vec<f64>, Vec<f64>) = rows
                .iter()
                .filter_map(|r| (m.value)(r).map(|y| (r.step.max(1) as f64, y)))
                .unzip();
            let series = Series::new(label.clone(), xs, ys).markers();
            plot.push(series.color(RUN_COLOURS[i % RUN_COLOURS.len()]));
        }
        if !m.log_y {
            let lowest = plot.series.iter().flat_map(|s| s.ys.iter().copied());
            plot.y_min = Some(lowest.fold(0.0, f64::min));
        }
        write_atomic(&out.join(m.file), plot.to_svg().as_bytes())?;
    }
    write_atomic(&out.join("runs.md"), table(runs).as_bytes())?;
    Ok(())
}

/// Every run's every checkpoint, by step then run.
pub fn table(runs: &[(String, Vec<StudyRow>)]) -> String {
    let mut rows: Vec<(u64, &str, &StudyRow)> = runs
        .iter()
        .flat_map(|(label, rows)| rows.iter().map(move |r| (r.step, label.as_str(), r)))
        .collect();
    rows.sort_by_key(|&(step, _, _)| step);
    let columns: Vec<&str> = MEASURES.iter().map(|m| m.column).collect();
    let mut md = format!(
        "| step | run | {} |\n|{}\n",
        columns.join(" | "),
        "---|".repeat(columns.len() + 2)
    );
    for (step, label, r) in rows {
        let cells: Vec<String> = MEASURES
            .iter()
            .map(|m| (m.value)(r).map_or("-".into(), |v| format!("{v:.*}", m.digits)))
            .collect();
        let _ = writeln!(md, "| {step} | {label} | {} |", cells.join(" | "));
    }
    md
}
