//! The learning rule against backprop over a run, from `metrics.csv`: its columns, the plot
//! `alignment.svg` and the mean cosine per bucket.
//!
//! Every `cortex.train.alignment_every_steps` the trainer runs one more backprop sweep on
//! the step's tape and compares, per bucket, the rule's update with backprop's gradient
//! (`cortex::credit`). Its row of `metrics.csv` then holds `align_cos_{W,C,D,P}` (the
//! cosine: 1 where the rule points where backprop does, 0 orthogonal, negative uphill) and
//! the Frobenius norms `rule_norm_*`, `backprop_norm_*`; the other rows leave them empty,
//! as does a bucket without parameters.

use crate::run::error::RunError;
use colorimetry::plot::{LinePlot, Series};
use cortex::credit::Alignment;
use std::fmt::Write as _;
use std::path::Path;

/// The buckets the columns are named after, in order.
pub const BUCKETS: [&str; 4] = ["W", "C", "D", "P"];

/// The alignment columns of `metrics.csv`, comma-separated, without a leading comma.
pub const COLUMNS: &str = "align_cos_W,align_cos_C,align_cos_D,align_cos_P,\
rule_norm_W,rule_norm_C,rule_norm_D,rule_norm_P,\
backprop_norm_W,backprop_norm_C,backprop_norm_D,backprop_norm_P";

/// The cells of the alignment columns of one row, each with its leading comma.
pub fn cells(alignment: Option<&Alignment>) -> String {
    let mut row = String::new();
    let value = |a: &Alignment, k: usize, what: usize| {
        a[k].and_then(|g| match what {
            0 => g.cosine,
            1 => Some(g.rule_norm),
            _ => Some(g.backprop_norm),
        })
    };
    for what in 0..3 {
        for k in 0..BUCKETS.len() {
            match alignment.and_then(|a| value(a, k, what)) {
                Some(v) => {
                    let _ = write!(row, ",{v}");
                }
                None => row.push(','),
            }
        }
    }
    row
}

/// `(step, cosine per bucket)` of every measured row of the `metrics.csv` at `path` (empty
/// when the file is unreadable or has no alignment columns).
pub fn cosines(path: &Path) -> Vec<(u64, [Option<f64>; 4])> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let cols: Vec<Option<usize>> = BUCKETS
        .iter()
        .map(|b| header.iter().position(|h| *h == format!("align_cos_{b}")))
        .collect();
    lines
        .filter_map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            let step = f.first()?.parse().ok()?;
            let c: [Option<f64>; 4] =
                std::array::from_fn(|k| cols[k].and_then(|i| f.get(i)?.parse().ok()));
            c.iter().any(Option::is_some).then_some((step, c))
        })
        .collect()
}

/// The mean cosine per bucket over the measured rows.
pub fn mean_cosines(rows: &[(u64, [Option<f64>; 4])]) -> [Option<f64>; 4] {
    std::array::from_fn(|k| {
        let v: Vec<f64> = rows.iter().filter_map(|r| r.1[k]).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    })
}

/// Writes `out/alignment.svg` from `out/metrics.csv`; `false` when nothing was measured.
pub fn write_plot(out: &Path) -> Result<bool, RunError> {
    let rows = cosines(&out.join("metrics.csv"));
    if rows.is_empty() {
        return Ok(false);
    }
    let mut plot = LinePlot::new(
        "The learning rule's update against backprop's gradient",
        "step",
        "cosine",
    );
    (plot.y_min, plot.y_max) = (Some(-1.0), Some(1.0));
    for (k, bucket) in BUCKETS.iter().enumerate() {
        let (xs, ys): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter_map(|(s, c)| Some((*s as f64, c[k]?)))
            .unzip();
        if !xs.is_empty() {
            plot.push(Series::new(*bucket, xs, ys));
        }
    }
    crate::io::write_atomic(&out.join("alignment.svg"), plot.to_svg().as_bytes())?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use autodiff::learn::GroupAlignment;

    #[test]
    fn cells_read_back_as_cosines_and_means() {
        let g = |c| {
            Some(GroupAlignment {
                cosine: Some(c),
                rule_norm: 2.0,
                backprop_norm: 3.0,
            })
        };
        let a: Alignment = [g(0.5), None, g(-0.25), g(1.0)];
        assert_eq!(cells(None), ",".repeat(12));
        let row = cells(Some(&a));
        assert_eq!(row, ",0.5,,-0.25,1,2,,2,2,3,,3,3");
        let dir = std::env::temp_dir().join(format!("cv_alignment_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = format!(
            "step,loss,{COLUMNS},dimension\n1,0.1{row},\n2,0.1{},\n",
            cells(None)
        );
        std::fs::write(dir.join("metrics.csv"), text).unwrap();
        let rows = cosines(&dir.join("metrics.csv"));
        assert_eq!(rows, vec![(1, [Some(0.5), None, Some(-0.25), Some(1.0)])]);
        assert_eq!(
            mean_cosines(&rows),
            [Some(0.5), None, Some(-0.25), Some(1.0)]
        );
        assert!(write_plot(&dir).unwrap() && dir.join("alignment.svg").exists());
        std::fs::remove_dir_all(dir).ok();
    }
}
