//! The gathered table: which settings to show, and the CSV and Markdown texts.
//!
//! Columns: the run's folder, the settings that vary, status (with the error of a failed run),
//! steps done, wall time (s), the dimension CMF-SIM measured at the end with each K's converged
//! margin (worst error / threshold of the reported set; < 1 passes), the held-out prediction
//! gain ("next frame = this frame" error over the cortex's), and the learned invariants
//! against the eye's truth: C recall by nearest class centre and d′ per class, W's surround
//! correlation and DC gain, P's position error after the affine gauge (cone spacings RMS), and
//! what the eye hides recovered (per class, the held-out R² of its own signal at the other
//! classes' cones, [`science::invariants::hidden`]) and which colour directions the percept
//! carries (per principal direction of the cone excitations, strongest first, the held-out R²
//! of its projection, [`science::invariants::directions`]; empty for runs measured before it).
//! The Markdown cells are formatted as the README's tables; the CSV keeps full precision.

use super::Run;
use std::collections::{BTreeMap, BTreeSet};

/// The settings worth a column: those that differ between runs, less those that say the same
/// as one already kept — split the runs into the same groups (a derived seed follows `seed`,
/// `[retina] cones` follows `cones`). A setting that only together with several kept ones
/// singles out its runs keeps its column: one run on a larger eye shows its eye size even when
/// its cones, seed and steps already make its row unique. When a run measures or saves
/// (`schedule.*`, the checkpoint interval) gets no column unless named in `first`. Candidates are taken in order:
/// `first` (a sweep's grid keys), then shallow keys before nested ones, then by name.
pub fn varying_keys(runs: &[Run], first: &[String]) -> Vec<String> {
    let rows: Vec<&BTreeMap<String, String>> = runs
        .iter()
        .map(|r| &r.settings)
        .filter(|s| !s.is_empty())
        .collect();
    let all: BTreeSet<&String> = rows.iter().flat_map(|s| s.keys()).collect();
    let varies = |k: &String| {
        let mut values = rows.iter().map(|s| s.get(k));
        let v0 = values.next().flatten();
        values.any(|v| v != v0)
    };
    let mut order: Vec<&String> = first.iter().filter(|k| all.contains(k)).collect();
    let mut rest: Vec<&String> = all
        .iter()
        .copied()
        .filter(|k| !first.contains(k) && !is_bookkeeping(k))
        .collect();
    rest.sort_by_key(|k| (k.matches('.').count(), k.as_str()));
    order.extend(rest);
    let mut kept: Vec<String> = Vec::new();
    for key in order.into_iter().filter(|k| varies(k)) {
        let same_as_kept = kept.iter().any(|k| {
            let rows = rows.as_slice();
            follows(rows, key, k) && follows(rows, k, key)
        });
        if !same_as_kept {
            kept.push(key.clone());
        }
    }
    kept
}

/// Settings that change when a run measures, draws or saves, not what its cortex learns; they
/// get a column only as a sweep's grid key.
const BOOKKEEPING: [&str; 2] = ["schedule.", "cortex.train.checkpoint_every_steps"];

fn is_bookkeeping(key: &str) -> bool {
    BOOKKEEPING.iter().any(|b| key.starts_with(b))
}

/// Whether setting `b`'s value is a function of setting `a`'s over `rows`.
fn follows(rows: &[&BTreeMap<String, String>], b: &str, a: &str) -> bool {
    let mut seen: BTreeMap<Option<&String>, Option<&String>> = BTreeMap::new();
    rows.iter()
        .all(|s| *seen.entry(s.get(a)).or_insert(s.get(b)) == s.get(b))
}

/// The numbers of a finished run, formatted for reading (empty when not measured).
struct Cells {
    dimension: String,
    gain: String,
    c_recall: String,
    c_dprime: String,
    w_surround: String,
    w_dc: String,
    p_error: String,
    hidden: String,
    directions: String,
    wall: String,
}

fn cells(run: &Run) -> Option<Cells> {
    let s = run.summary.as_ref()?;
    let margins = science::summary::margins_text(&s.converged_ratio_per_k);
    // 0 is "undefined" when measured (the verdict says why), "not measured" otherwise.
    let measured = !s.dimension_over_steps.is_empty();
    let why = s.verdict.split(':').next().unwrap_or_default();
    let dimension = match (measured, margins.is_empty(), s.dimension) {
        (false, _, _) => String::new(),
        (true, true, 0) => format!("undefined ({why})"),
        (true, false, 0) => format!("undefined ({margins})"),
        (true, _, d) => format!("{d} ({margins})"),
    };
    let dimension = with_other_location_seeds(run, dimension);
    let rec = s.invariants.as_ref().map(|i| &i.recovery);
    let c = rec.and_then(|r| r.c.as_ref());
    let w = rec.and_then(|r| r.w.as_ref());
    Some(Cells {
        dimension,
        gain: s
            .heldout_prediction
            .map_or(String::new(), |p| format!("{:.1}", p[2])),
        c_recall: c.map_or(String::new(), |c| {
            science::invariants::per_class(&c.recall_nearest_centroid, 2)
        }),
        c_dprime: c.map_or(String::new(), |c| {
            science::invariants::per_class(&c.dprime, 1)
        }),
        w_surround: w.map_or(String::new(), |w| format!("{:.2}", w.surround_r)),
        w_dc: w.map_or(String::new(), |w| format!("{:.3}", w.dc_gain)),
        p_error: rec.map_or(String::new(), |r| {
            format!("{:.2}", r.p.position_error_rms_cones)
        }),
        hidden: rec
            .and_then(|r| r.hidden.as_ref())
            .map_or(String::new(), |h| {
                science::invariants::per_class(&h.unique_r2, 2)
            }),
        directions: rec
            .and_then(|r| r.directions.as_ref())
            .map_or(String::new(), |d| science::invariants::per_class(&d.r2, 2)),
        wall: format!("{:.0}", s.wall_seconds),
    })
}

/// `own`, the dimension cell of the run's own location seed, with the dimensions its final
/// checkpoint measured at other location seeds: led by their median ([`Run::dimension`]) when
/// there is one, so that the figure first in the cell is the run's.
fn with_other_location_seeds(run: &Run, own: String) -> String {
    let others = run.other_location_seeds.as_slice();
    if others.is_empty() {
        return own;
    }
    // A measured 0 is an undefined verdict (no colour constancy, or every K tried failed).
    let word = |d: usize| match d {
        0 => "undefined".to_string(),
        d => d.to_string(),
    };
    let seeds: Vec<String> = (others.iter())
        .map(|&(l, d)| format!("{} at {l}", word(d)))
        .collect();
    let seeds = seeds.join(", ");
    match (
        run.location_median().map(|(m, n)| (word(m), n)),
        own.is_empty(),
    ) {
        (Some((median, n)), false) => {
            format!("{median} (median of {n} location seeds; its own: {own}; the others: {seeds})")
        }
        (Some((median, n)), true) => format!("{median} (median of {n} location seeds: {seeds})"),
        (None, false) => format!("{own}; other location seeds: {seeds}"),
        (None, true) => format!("location seeds: {seeds}"),
    }
}

/// A finished run's measured dimension with its margins (`3 (K1 9.41, K2 4.53, K3 0.70)`);
/// empty when it has none.
pub(super) fn dimension_cell(run: &Run) -> String {
    cells(run).map_or(String::new(), |c| c.dimension)
}

fn status_cell(run: &Run) -> String {
    match run.status.detail() {
        d if d.is_empty() => run.status.word().to_string(),
        d => format!("{}: {d}", run.status.word()),
    }
}

/// A cell's text made safe for a Markdown table row.
pub(super) fn md_escape(s: &str) -> String {
    s.replace('|', "\\|").replace(['\n', '\r'], " ")
}

/// The readable table's cell for a setting absent from a run's config: an optional setting
/// left unset (e.g. no tetrachromatic environment). The CSV leaves it empty.
pub const UNSET_SETTING: &str = "(unset)";

/// Position of the dimension column in [`display`]'s rows, after the run, the `keys` settings,
/// status, steps, wall time and the paper's figure.
pub fn dimension_column(keys: &[String]) -> usize {
    keys.len() + 5
}

/// The dimension the paper reports for a run's settings ([`science::paper`]), or "—".
fn paper_cell(run: &Run) -> String {
    science::paper::reported_for_settings(&run.settings).map_or("—".into(), |r| r.to_string())
}

/// The readable table (Markdown and HTML): its header and one row of plain-text cells per run.
pub fn display(runs: &[Run], keys: &[String]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut head = vec!["run".to_string()];
    head.extend(keys.iter().cloned());
    head.extend(
        [
            "status",
            "steps done",
            "wall s",
            "paper",
            "CMF-SIM (margins)",
            "gain",
            "C recall",
            "C d′",
            "W surround r",
            "W DC",
            "P error",
            "hidden R²",
            "directions R²",
        ]
        .map(String::from),
    );
    let rows = runs
        .iter()
        .map(|run| {
            let mut row = vec![run.folder.clone()];
            row.extend(keys.iter().map(|k| {
                let value = run.settings.get(k).cloned();
                value.unwrap_or_else(|| UNSET_SETTING.to_string())
            }));
            row.push(status_cell(run));
            row.push(run.steps.map_or(String::new(), |s| s.to_string()));
            let paper = paper_cell(run);
            match cells(run) {
                Some(c) => row.extend([
                    c.wall,
                    paper,
                    c.dimension,
                    c.gain,
                    c.c_recall,
                    c.c_dprime,
                    c.w_surround,
                    c.w_dc,
                    c.p_error,
                    c.hidden,
                    c.directions,
                ]),
                None => {
                    row.push(String::new());
                    row.push(paper);
                    row.extend(std::iter::repeat_n(String::new(), 9));
                }
            }
            row
        })
        .collect();
    (head, rows)
}

/// A dimension cell (`3 (K1 …)`) with its leading number wrapped in `open … close`.
pub fn emphasise_number(cell: &str, open: &str, close: &str) -> String {
    let digits = cell.chars().take_while(char::is_ascii_digit).count();
    match digits {
        0 => cell.to_string(),
        n => format!("{open}{}{close}{}", &cell[..n], &cell[n..]),
    }
}

/// The Markdown table of `runs` with a column per setting of `keys` (the dimension in bold).
pub fn markdown(runs: &[Run], keys: &[String]) -> String {
    let (head, rows) = display(runs, keys);
    let mut out = format!("| {} |\n", head.join(" | "));
    out.push_str(&format!("|{}\n", "---|".repeat(head.len())));
    let dim = dimension_column(keys);
    for mut row in rows {
        row[dim] = emphasise_number(&row[dim], "**", "**");
        let row: Vec<String> = row.iter().map(|c| md_escape(c)).collect();
        out.push_str(&format!("| {} |\n", row.join(" | ")));
    }
    out
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The CSV table of `runs` (one margin column per K tried by any run).
pub fn csv(runs: &[Run], keys: &[String]) -> String {
    let max_k = runs
        .iter()
        .filter_map(|r| r.summary.as_ref())
        .flat_map(|s| s.converged_ratio_per_k.iter().map(|(k, _)| *k))
        .max()
        .unwrap_or(0);
    let mut head = vec!["run".to_string()];
    head.extend(keys.iter().cloned());
    head.extend(
        [
            "status",
            "detail",
            "steps_done",
            "wall_seconds",
            "paper_dimension",
            "dimension",
            "verdict",
        ]
        .map(String::from),
    );
    head.extend((1..=max_k).map(|k| format!("margin_k{k}")));
    head.extend(
        [
            "heldout_gain",
            "c_classes",
            "c_recall",
            "c_dprime",
            "w_surround_r",
            "w_dc_gain",
            "p_error_rms_cones",
            "hidden_r2",
            "directions_r2",
        ]
        .map(String::from),
    );
    let mut out = head.join(",") + "\n";
    let num = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
    for run in runs {
        let mut row = vec![run.folder.clone()];
        row.extend(
            keys.iter()
                .map(|k| run.settings.get(k).cloned().unwrap_or_default()),
        );
        row.push(run.status.word().into());
        row.push(run.status.detail());
        row.push(run.steps.map_or(String::new(), |s| s.to_string()));
        let s = run.summary.as_ref();
        row.push(num(s.map(|s| s.wall_seconds)));
        let paper = science::paper::reported_for_settings(&run.settings);
        row.push(paper.map_or(String::new(), |r| r.to_string()));
        let dimension = run.dimension().or(s.map(|s| s.dimension));
        row.push(dimension.map_or(String::new(), |d| d.to_string()));
        row.push(s.map_or(String::new(), |s| s.verdict.clone()));
        for k in 1..=max_k {
            let m = s.and_then(|s| s.converged_ratio_per_k.iter().find(|(j, _)| *j == k));
            row.push(num(m.map(|(_, r)| *r)));
        }
        row.push(num(s.and_then(|s| s.heldout_prediction).map(|p| p[2])));
        let rec = s.and_then(|s| s.invariants.as_ref()).map(|i| &i.recovery);
        let c = rec.and_then(|r| r.c.as_ref());
        let w = rec.and_then(|r| r.w.as_ref());
        row.push(c.map_or(String::new(), |c| c.classes.join("/")));
        row.push(c.map_or(String::new(), |c| {
            science::invariants::per_class(&c.recall_nearest_centroid, 4)
        }));
        row.push(c.map_or(String::new(), |c| {
            science::invariants::per_class(&c.dprime, 4)
        }));
        row.push(num(w.map(|w| w.surround_r)));
        row.push(num(w.map(|w| w.dc_gain)));
        row.push(num(rec.map(|r| r.p.position_error_rms_cones)));
        row.push(
            rec.and_then(|r| r.hidden.as_ref())
                .map_or(String::new(), |h| {
                    science::invariants::per_class(&h.unique_r2, 4)
                }),
        );
        row.push(
            rec.and_then(|r| r.directions.as_ref())
                .map_or(String::new(), |d| science::invariants::per_class(&d.r2, 4)),
        );
        let row: Vec<String> = row.iter().map(|c| csv_field(c)).collect();
        out.push_str(&(row.join(",") + "\n"));
    }
    out
}

#[cfg(test)]
mod tests;
