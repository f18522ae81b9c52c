//! The convergence table and plots of a run: `convergence.md` (one row per checkpoint, its
//! caption saying what each column measures), `convergence.json` (the rows as measured) and
//! `convergence_invariants.svg` / `convergence_measures.svg` (the measures over steps, log x).

use super::{CheckpointCmf, StudyRow, VerdictOverCheckpoints};
use crate::io::write_atomic;
use crate::run::error::RunError;
use colorimetry::plot::{LinePlot, Series};
use science::config::RunConfig;
use science::invariants;
use std::fmt::Write as _;
use std::path::Path;

pub(super) fn describe_row(row: &StudyRow) -> String {
    let mut s = String::new();
    if let Some(g) = row.heldout_gain {
        let _ = write!(s, "prediction {g:.1}× better than \"next = current\"; ");
    }
    if let Some(c) = &row.cmf {
        let _ = write!(s, "CMF-SIM {}-D; ", c.dimension);
    }
    s + &row.recovery.describe().join("; ")
}

pub(super) fn min_of(v: &[f64]) -> f64 {
    v.iter().cloned().fold(f64::INFINITY, f64::min)
}

fn fmt_list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.2}"))
        .collect::<Vec<_>>()
        .join("/")
}

/// The table in Markdown, one row per checkpoint, ending with CMF-SIM's verdict over the
/// checkpoints and the run's `last` measurement (see
/// [`VerdictOverCheckpoints::with_final`](super::VerdictOverCheckpoints::with_final)).
pub fn table(config: &RunConfig, rows: &[StudyRow], last: Option<CheckpointCmf>) -> String {
    let mut md = format!(
        "Convergence of `{}` {} (seed {}), one row per checkpoint measured. Gain: held-out \
         prediction error of \"next = current\" over the model's. CMF-SIM: dimension, and per K \
         the converged worst error/threshold of the best set (pass < 1). C recall per class \
         (k-means matched / nearest class centre). W: surround r against the DoG and DC gain \
         (true {}). P: position error after the affine gauge, cone spacings RMS. Hidden: per \
         class, the held-out R² of its own signal (what the other classes do not tell) read from \
         the percept at the other classes' cones (1: demosaicked; 0: not carried). Directions: \
         per principal direction of the cone excitations, strongest (luminance-like) first, the \
         held-out R² of its projection read from the percept (1: carried; 0: not). Both {}.\n\n",
        config.preset,
        config.cones,
        config.seed,
        rows.iter()
            .find_map(|r| r.recovery.w.as_ref())
            .map_or("-".into(), |w| format!("{:.3}", w.true_dc_gain)),
        held_out_scenes_in_words(rows),
    );
    md.push_str("| step | wall s | gain | CMF-SIM | C recall k-means | C recall centre | C d′ | W surround r | W DC | P error | P spacing r | hidden R² | directions R² |\n");
    md.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let cmf = r.cmf.as_ref().map_or("-".into(), |c| {
            let ks: Vec<String> = c
                .per_k
                .iter()
                .map(|k| format!("K{}: {:.2}", k[0], k[2]))
                .collect();
            format!("{}-D ({})", c.dimension, ks.join(", "))
        });
        let (ck, cc, cd) =
            r.recovery
                .c
                .as_ref()
                .map_or(("-".into(), "-".into(), "-".into()), |c| {
                    (
                        fmt_list(&c.recall_kmeans),
                        fmt_list(&c.recall_nearest_centroid),
                        fmt_list(&c.dprime),
                    )
                });
        let (ws, wd) = r.recovery.w.as_ref().map_or(("-".into(), "-".into()), |w| {
            (format!("{:.2}", w.surround_r), format!("{:.3}", w.dc_gain))
        });
        let hidden = r
            .recovery
            .hidden
            .as_ref()
            .map_or("-".into(), |h| invariants::per_class(&h.unique_r2, 2));
        let directions = r
            .recovery
            .directions
            .as_ref()
            .map_or("-".into(), |d| invariants::per_class(&d.r2, 2));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {cmf} | {ck} | {cc} | {cd} | {ws} | {wd} | {:.2} | {:.2} | {hidden} | {directions} |",
            r.step,
            r.wall_seconds.map_or("-".into(), |w| format!("{w:.0}")),
            r.heldout_gain.map_or("-".into(), |g| format!("{g:.1}")),
            r.recovery.p.position_error_rms_cones,
            r.recovery.p.spacing_r,
        );
    }
    let points = VerdictOverCheckpoints::points_of(rows);
    if let Some(verdict) = VerdictOverCheckpoints::with_final(points, last) {
        let _ = write!(md, "\n{}\n", verdict.describe());
    }
    md
}

/// The held-out scenes of `rows` in words: "on 32 held-out scenes, the first half fitting, the
/// second scoring", or the count per step where rows differ.
fn held_out_scenes_in_words(rows: &[StudyRow]) -> String {
    let counts: Vec<usize> = rows.iter().map(|r| r.held_out_scenes).collect();
    let scenes = match counts.first() {
        Some(&n) if counts.iter().all(|&c| c == n) => format!("{n}"),
        Some(_) => {
            let per_step: Vec<String> = rows
                .iter()
                .map(|r| format!("{} at step {}", r.held_out_scenes, r.step))
                .collect();
            per_step.join(", ")
        }
        None => format!("{}", invariants::HELD_OUT_SCENES),
    };
    format!("on {scenes} held-out scenes, the first half fitting, the second scoring")
}
pub(super) fn write_outputs(
    out: &Path,
    config: &RunConfig,
    rows: &[StudyRow],
    last: Option<CheckpointCmf>,
) -> Result<(), RunError> {
    let json = serde_json::to_string_pretty(rows).expect("plain data");
    write_atomic(&out.join("convergence.json"), json.as_bytes())?;
    let points = VerdictOverCheckpoints::points_of(rows);
    let json = serde_json::to_string_pretty(&points).expect("plain data");
    write_atomic(&out.join(super::CMF_FILE), json.as_bytes())?;
    write_atomic(
        &out.join("convergence.md"),
        table(config, rows, last).as_bytes(),
    )?;
    let x: Vec<f64> = rows.iter().map(|r| r.step.max(1) as f64).collect();
    let series = |name: &str, f: &dyn Fn(&StudyRow) -> Option<f64>| {
        let (xs, ys): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .zip(&x)
            .filter_map(|(r, &x)| f(r).map(|y| (x, y)))
            .unzip();
        Series::new(name, xs, ys).markers()
    };
    let mut recovered = LinePlot::new(
        "Learned invariants against the truth (1 = recovered)",
        "step",
        "score",
    );
    recovered.x.log = true;
    recovered.y_max = Some(1.05);
    recovered.push(series("C worst recall (k-means)", &|r| {
        r.recovery.c.as_ref().map(|c| min_of(&c.recall_kmeans))
    }));
    recovered.push(series("C worst recall (nearest centre)", &|r| {
        r.recovery
            .c
            .as_ref()
            .map(|c| min_of(&c.recall_nearest_centroid))
    }));
    recovered.push(series("W surround r", &|r| {
        r.recovery.w.as_ref().map(|w| w.surround_r)
    }));
    recovered.push(series("P spacing r", &|r| Some(r.recovery.p.spacing_r)));
    let classes = rows
        .iter()
        .find_map(|r| r.recovery.hidden.as_ref())
        .map_or(Vec::new(), |h| h.classes.clone());
    for (k, name) in classes.iter().enumerate() {
        recovered.push(series(&format!("hidden {name} R²"), &|r| {
            r.recovery
                .hidden
                .as_ref()
                .and_then(|h| h.unique_r2.get(k).copied())
                .filter(|v| v.is_finite())
        }));
    }
    // From 0, or lower where a correlation is negative.
    let lowest = recovered.series.iter().flat_map(|s| s.ys.iter().copied());
    recovered.y_min = Some(lowest.fold(0.0, f64::min));
    write_atomic(
        &out.join("convergence_invariants.svg"),
        recovered.to_svg().as_bytes(),
    )?;
    let mut errors = LinePlot::new(
        "Prediction gain, W DC factor, P error, CMF-SIM dimension",
        "step",
        "value",
    );
    (errors.x.log, errors.y.log) = (true, true);
    errors.push(series("held-out prediction gain (×)", &|r| r.heldout_gain));
    errors.push(series("W DC gain / true (factor ≥ 1)", &|r| {
        r.recovery.w.as_ref().map(|w| w.dc_factor())
    }));
    errors.push(series("P error, cone spacings RMS", &|r| {
        Some(r.recovery.p.position_error_rms_cones)
    }));
    // Measured at checkpoints only: held until the next one.
    let mut dimension = series("CMF-SIM dimension", &|r| {
        r.cmf
            .as_ref()
            .filter(|c| c.dimension > 0)
            .map(|c| c.dimension as f64)
    });
    dimension.steps = true;
    errors.push(dimension);
    write_atomic(
        &out.join("convergence_measures.svg"),
        errors.to_svg().as_bytes(),
    )?;
    Ok(())
}
