//! `index.html` of a gathered folder: the gathered table as one self-contained page, each run
//! linked to its own `report.html` and shown with its dimension over training.
//!
//! Like a run's report ([`crate::report`]) the page has no script and loads nothing: each
//! run's `dimension.svg` is embedded as a `data:` URI; the links to the runs' `report.html`
//! are relative, so the folder can be copied or opened offline as a whole. A run without a
//! report (pending, stopped, failed) is listed without a link.

use super::table::{dimension_column, display, emphasise_number};
use super::Run;
use crate::report::{base64, escape, REPORT_FILE, STYLE};
use crate::run::error::RunError;
use std::fmt::Write as _;
use std::path::Path;

/// Name of the page in a gathered folder.
pub const INDEX_FILE: &str = "index.html";

/// Height of the embedded dimension plots, px.
const THUMBNAIL_HEIGHT_PX: u32 = 160;

/// Wider than a run's report: a table of many columns and a plot per row.
const WIDE: &str = "body{max-width:1700px}td img{display:block}";

/// The page for the runs of `dir` with a column per setting of `keys`.
pub fn render(dir: &Path, runs: &[Run], keys: &[String]) -> String {
    let title = format!("colorvision: {} runs in {}", runs.len(), dir.display());
    let mut html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>{t}</title><style>{STYLE}{WIDE}</style></head><body>\n<h1>{t}</h1>\n\
         <p>Each run's folder links to its report. Dimension: CMF-SIM's verdict at the end \
         with each K's converged margin (worst error over threshold of the best set; below 1 \
         passes). Gain: held-out prediction error of \"next frame = this frame\" over the \
         cortex's. C, W, P: the learned invariants against the eye's truth.</p>\n",
        t = escape(&title),
    );
    let (head, rows) = display(runs, keys);
    html.push_str("<table>\n<tr>");
    for h in head
        .iter()
        .chain(std::iter::once(&"dimension over training".into()))
    {
        let _ = write!(html, "<th>{}</th>", escape(h));
    }
    html.push_str("</tr>\n");
    let dim = dimension_column(keys);
    for (run, row) in runs.iter().zip(rows) {
        html.push_str("<tr>");
        for (i, cell) in row.iter().enumerate() {
            let text = escape(cell);
            let _ = match i {
                0 => write!(html, "<td>{}</td>", folder_cell(dir, run, &text)),
                i if i == dim => {
                    write!(html, "<td>{}</td>", emphasise_number(&text, "<b>", "</b>"))
                }
                _ => write!(html, "<td>{text}</td>"),
            };
        }
        let _ = writeln!(html, "<td>{}</td></tr>", thumbnail(dir, run));
    }
    html.push_str("</table>\n</body></html>\n");
    html
}

/// The run's folder, linked to its report when it has one.
fn folder_cell(dir: &Path, run: &Run, text: &str) -> String {
    let report = Path::new(&run.folder).join(REPORT_FILE);
    if dir.join(&report).is_file() {
        let href = escape(&report.to_string_lossy().replace('\\', "/"));
        format!("<a href=\"{href}\">{text}</a>")
    } else {
        text.to_string()
    }
}

/// The run's `dimension.svg`, embedded small, or nothing.
fn thumbnail(dir: &Path, run: &Run) -> String {
    match std::fs::read(dir.join(&run.folder).join("dimension.svg")) {
        Ok(svg) => format!(
            "<img alt=\"dimension over training\" height=\"{THUMBNAIL_HEIGHT_PX}\" \
             src=\"data:image/svg+xml;base64,{}\">",
            base64(&svg)
        ),
        Err(_) => String::new(),
    }
}

/// Writes `dir/index.html`.
pub fn write(dir: &Path, runs: &[Run], keys: &[String]) -> Result<(), RunError> {
    let html = render(dir, runs, keys);
    Ok(crate::io::write_atomic(
        &dir.join(INDEX_FILE),
        html.as_bytes(),
    )?)
}
