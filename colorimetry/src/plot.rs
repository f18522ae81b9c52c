//! A small dependency-free SVG line plot (CMF-SIM error curves, CMFs, loss curves …).
//!
//! ```
//! use colorimetry::plot::{LinePlot, Series};
//! let mut p = LinePlot::new("loss", "step", "loss");
//! p.push(Series::new("train", vec![0.0, 1.0, 2.0], vec![1.0, 0.5, 0.3]));
//! p.log_y = true;
//! let svg = p.to_svg();
//! assert!(svg.starts_with("<svg"));
//! ```
//!
//! Coordinates: data x to the right, y up. With `log_y`, non-positive values (and values below
//! `y_min`, if set) are clipped to the bottom of the axis. Non-finite points break the line.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::Result;

/// Default colour cycle (Okabe–Ito palette, colour-blind safe).
pub const PALETTE: [&str; 8] = [
    "#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442",
];

/// One line.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// x values.
    pub xs: Vec<f64>,
    /// y values (same length as `xs`).
    pub ys: Vec<f64>,
    /// CSS colour; `None` takes the next palette colour.
    pub color: Option<String>,
    /// Dashed line.
    pub dashed: bool,
}

impl Series {
    /// A solid line with an automatic colour.
    pub fn new(name: impl Into<String>, xs: Vec<f64>, ys: Vec<f64>) -> Self {
        Series {
            name: name.into(),
            xs,
            ys,
            color: None,
            dashed: false,
        }
    }
    /// Builder: dashed.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
    /// Builder: colour.
    pub fn color(mut self, c: impl Into<String>) -> Self {
        self.color = Some(c.into());
        self
    }
}

/// A line plot with axes, ticks, grid and legend.
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    /// Title on top.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Lower y limit (data units); `None` = automatic.
    pub y_min: Option<f64>,
    /// Upper y limit (data units); `None` = automatic.
    pub y_max: Option<f64>,
    /// Width, px.
    pub width_px: f64,
    /// Height, px.
    pub height_px: f64,
}

impl LinePlot {
    /// An empty 720×440 plot.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        LinePlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            log_y: false,
            y_min: None,
            y_max: None,
            width_px: 720.0,
            height_px: 440.0,
        }
    }

    /// Add a line.
    pub fn push(&mut self, s: Series) {
        assert_eq!(
            s.xs.len(),
            s.ys.len(),
            "LinePlot::push: {} xs vs {} ys",
            s.xs.len(),
            s.ys.len()
        );
        self.series.push(s);
    }

    fn y_tf(&self, y: f64) -> f64 {
        if self.log_y {
            if y > 0.0 {
                y.log10()
            } else {
                f64::NEG_INFINITY
            }
        } else {
            y
        }
    }

    /// Render to an SVG document.
    pub fn to_svg(&self) -> String {
        let (w, h) = (self.width_px, self.height_px);
        let (ml, mr, mt, mb) = (78.0, 170.0, 36.0, 52.0);
        let (pw, ph) = (w - ml - mr, h - mt - mb);
        let finite = |v: &f64| v.is_finite();
        let xs: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.xs.iter().copied())
            .filter(finite)
            .collect();
        let ys: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.ys.iter().map(|&y| self.y_tf(y)))
            .filter(finite)
            .collect();
        let (mut x0, mut x1) = min_max(&xs).unwrap_or((0.0, 1.0));
        let (mut y0, mut y1) = min_max(&ys).unwrap_or((0.0, 1.0));
        if let Some(v) = self.y_min {
            y0 = self.y_tf(v);
        }
        if let Some(v) = self.y_max {
            y1 = self.y_tf(v);
        }
        if !(y0.is_finite() && y1.is_finite()) || y1 <= y0 {
            (y0, y1) = (y0.min(y1) - 0.5, y0.max(y1) + 0.5);
            if !y0.is_finite() {
                (y0, y1) = (0.0, 1.0);
            }
        }
        if x1 <= x0 {
            (x0, x1) = (x0 - 0.5, x1 + 0.5);
        }
        let px = |x: f64| ml + (x - x0) / (x1 - x0) * pw;
        let py = |y: f64| mt + ph - (y.clamp(y0, y1) - y0) / (y1 - y0) * ph;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="14">{}</text>"#,
            ml + pw / 2.0,
            esc(&self.title)
        );
        for t in nice_ticks(x0, x1, 8) {
            let x = px(t);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{mt}" x2="{x:.1}" y2="{:.1}" stroke="#e5e5e5"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                mt + ph,
                mt + ph + 16.0,
                fmt_tick(t)
            );
        }
        let yt = if self.log_y {
            log_ticks(y0, y1)
        } else {
            nice_ticks(y0, y1, 7)
        };
        for t in yt {
            let y = py(t);
            let label = if self.log_y {
                format!("1e{}", t.round() as i64)
            } else {
                fmt_tick(t)
            };
            let _ = writeln!(
                s,
                r##"<line x1="{ml}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#e5e5e5"/><text x="{:.1}" y="{:.1}" text-anchor="end">{label}</text>"##,
                ml + pw,
                ml - 6.0,
                y + 4.0
            );
        }
        let _ = writeln!(
            s,
            r##"<rect x="{ml}" y="{mt}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            ml + pw / 2.0,
            h - 12.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate(18,{}) rotate(-90)" text-anchor="middle">{}</text>"#,
            mt + ph / 2.0,
            esc(&self.y_label)
        );
        for (i, ser) in self.series.iter().enumerate() {
            let color = ser
                .color
                .clone()
                .unwrap_or_else(|| PALETTE[i % PALETTE.len()].to_string());
            let dash = if ser.dashed {
                r#" stroke-dasharray="6,4""#
            } else {
                ""
            };
            let mut d = String::new();
            let mut pen_down = false;
            for (&x, &y) in ser.xs.iter().zip(&ser.ys) {
                let mut ty = self.y_tf(y);
                if self.log_y && ty == f64::NEG_INFINITY {
                    ty = y0;
                }
                if !(x.is_finite() && ty.is_finite()) {
                    pen_down = false;
                    continue;
                }
                let _ = write!(
                    d,
                    "{}{:.2},{:.2} ",
                    if pen_down { "L" } else { "M" },
                    px(x),
                    py(ty)
                );
                pen_down = true;
            }
            let _ = writeln!(
                s,
                r#"<path d="{d}" fill="none" stroke="{color}" stroke-width="1.6"{dash}/>"#
            );
            let ly = mt + 14.0 + 18.0 * i as f64;
            let lx = ml + pw + 12.0;
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{color}" stroke-width="2"{dash}/><text x="{}" y="{}">{}</text>"#,
                lx + 22.0,
                lx + 28.0,
                ly + 4.0,
                esc(&ser.name)
            );
        }
        s.push_str("</svg>\n");
        s
    }

    /// Write the SVG to `path` atomically ([`atomic_io::write_atomic`]), creating its folder.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        Ok(atomic_io::write_atomic(
            path.as_ref(),
            self.to_svg().as_bytes(),
        )?)
    }
}

fn min_max(v: &[f64]) -> Option<(f64, f64)> {
    if v.is_empty() {
        return None;
    }
    Some(
        v.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            }),
    )
}

/// "Nice" tick positions (1, 2, 5 × 10^k steps) covering `[lo, hi]`, about `n` of them.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let span = hi - lo;
    if !(span > 0.0) || !span.is_finite() {
        return vec![lo];
    }
    let raw = span / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let (a, b) = (lo.ceil() as i64, hi.floor() as i64);
    let every = (((b - a) as f64) / 8.0).ceil().max(1.0) as i64;
    (a..=b)
        .filter(|e| (e - a) % every == 0)
        .map(|e| e as f64)
        .collect()
}

fn fmt_tick(t: f64) -> String {
    if t == 0.0 {
        "0".into()
    } else if t.abs() >= 1e4 || t.abs() < 1e-3 {
        format!("{t:.1e}")
    } else {
        let s = format!("{t:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_one_path_per_series_and_escapes_text() {
        let mut p = LinePlot::new("a < b", "x", "y");
        p.push(Series::new("one", vec![0.0, 1.0, 2.0], vec![0.0, 1.0, 4.0]));
        p.push(Series::new("two & more", vec![0.0, 2.0], vec![1.0, f64::NAN]).dashed());
        let svg = p.to_svg();
        assert_eq!(svg.matches("<path").count(), 2);
        assert!(svg.contains("a &lt; b") && svg.contains("two &amp; more"));
        assert!(svg.contains("stroke-dasharray"));
        assert!(svg.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn log_axis_clips_non_positive_values() {
        let mut p = LinePlot::new("t", "x", "y");
        p.log_y = true;
        p.push(Series::new("s", vec![0.0, 1.0, 2.0], vec![1e-3, 0.0, 10.0]));
        let svg = p.to_svg();
        assert!(svg.contains("1e-3") && svg.contains("1e1"));
        assert!(!svg.contains("NaN") && !svg.contains("inf"));
    }

    #[test]
    fn nice_ticks_are_round() {
        assert_eq!(
            nice_ticks(400.0, 700.0, 6),
            vec![400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0]
        );
        let t = nice_ticks(0.0, 1.0, 5);
        let want = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0];
        assert_eq!(t.len(), want.len());
        assert!(t.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12));
        assert_eq!(fmt_tick(t[3]), "0.6");
    }
}
