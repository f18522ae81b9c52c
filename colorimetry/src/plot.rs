//! A small dependency-free SVG line plot (CMF-SIM error curves, CMFs, loss curves, dimension
//! over training …).
//!
//! ```
//! use colorimetry::plot::{LinePlot, Series};
//! let mut p = LinePlot::new("loss", "step", "loss");
//! p.push(Series::new("train", vec![0.0, 1.0, 2.0], vec![1.0, 0.5, 0.3]));
//! p.y.log = true;
//! let svg = p.to_svg();
//! assert!(svg.starts_with("<svg"));
//! ```
//!
//! Coordinates: data x to the right, y up. Each axis has a [`Scale`]: linear or log₁₀ (labelled
//! in data units, non-positive values and values below `y_min` clipped to the low edge),
//! integer (ticks at whole numbers only), and named ticks (`0 → "undefined"`). Non-finite
//! points break a line. A [`Series`] is a polyline or a step line (the value holds until the
//! next point), optionally with a marker at each point so a single point shows. The legend sits
//! right of the plot area inside the canvas: the canvas widens to fit the longest label.
//!
//! Why not a plotting crate: these plots need a few features (log axes, step lines, named
//! ticks, dashed series), byte-identical output for identical input, and no system fonts; the
//! SVG backends of plotting crates bring font handling and a larger build for none of them.

mod axis;
mod draw;

pub use axis::{fmt_number, nice_ticks, Scale, Tick};

use std::fmt::Write as _;
use std::path::Path;

use crate::error::Result;

/// Default colour cycle (Okabe–Ito palette, colour-blind safe).
pub const PALETTE: [&str; 8] = [
    "#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442",
];

/// Font size of tick labels and the legend, px; the title is 2 px larger.
const FONT_PX: f64 = 12.0;
/// Width of one character at [`FONT_PX`], px: an upper estimate for text of letters and digits
/// (DejaVu Sans, a common default sans-serif, draws digits 0.636 em wide), so a legend sized
/// with it is never narrower than drawn.
const CHAR_PX: f64 = 7.7;
/// Height of one legend row, px.
const LEGEND_ROW_PX: f64 = 18.0;
/// Narrowest plot area, px: a long legend widens the canvas instead of squeezing the plot.
const MIN_PLOT_PX: f64 = 480.0;
/// Margins left (tick labels, y label), top (title) and bottom (tick labels, x label), px.
const MARGIN_PX: [f64; 3] = [78.0, 36.0, 52.0];

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
    /// Step line: each value holds until the next point (for quantities measured now and then).
    pub steps: bool,
    /// A dot at each point.
    pub markers: bool,
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
            steps: false,
            markers: false,
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
    /// Builder: a dot at each point.
    pub fn markers(mut self) -> Self {
        self.markers = true;
        self
    }
    /// Builder: a step line with a dot at each measurement.
    pub fn steps(mut self) -> Self {
        self.steps = true;
        self.markers = true;
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
    /// Scale of the x axis.
    pub x: Scale,
    /// Scale of the y axis.
    pub y: Scale,
    /// Lower x limit (data units); `None` = automatic.
    pub x_min: Option<f64>,
    /// Upper x limit (data units); `None` = automatic.
    pub x_max: Option<f64>,
    /// Lower y limit (data units); `None` = automatic.
    pub y_min: Option<f64>,
    /// Upper y limit (data units); `None` = automatic.
    pub y_max: Option<f64>,
    /// Width of the canvas, px, unless the legend needs more.
    pub width_px: f64,
    /// Height of the canvas, px, unless the legend needs more.
    pub height_px: f64,
}

/// Where things go on the canvas: the plot area and the axis ranges (axis units).
struct Frame {
    left: f64,
    top: f64,
    width: f64,
    height: f64,
    x_range: (f64, f64),
    y_range: (f64, f64),
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        let (x0, x1) = self.x_range;
        self.left + (x.clamp(x0, x1) - x0) / (x1 - x0) * self.width
    }
    fn py(&self, y: f64) -> f64 {
        let (y0, y1) = self.y_range;
        self.top + self.height - (y.clamp(y0, y1) - y0) / (y1 - y0) * self.height
    }
}

impl LinePlot {
    /// An empty 720×440 plot with linear axes.
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
            x: Scale::default(),
            y: Scale::default(),
            x_min: None,
            x_max: None,
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

    /// Canvas size `(width, height)`, px: at least `width_px × height_px`, wider when the
    /// legend's longest label would leave the plot area narrower than `MIN_PLOT_PX`, taller
    /// when the legend's rows need it.
    pub fn canvas_px(&self) -> (f64, f64) {
        let [left, top, bottom] = MARGIN_PX;
        let width = self.width_px.max(left + MIN_PLOT_PX + self.legend_px());
        let rows = top + 14.0 + LEGEND_ROW_PX * self.series.len() as f64 + bottom;
        (width, self.height_px.max(rows))
    }

    /// Width right of the plot area, px: gap, line sample, the longest label, gap.
    fn legend_px(&self) -> f64 {
        let longest = self.series.iter().map(|s| s.name.chars().count()).max();
        longest.map_or(24.0, |n| 12.0 + 28.0 + n as f64 * CHAR_PX + 12.0)
    }

    fn frame(&self) -> Frame {
        let [left, top, bottom] = MARGIN_PX;
        let (w, h) = self.canvas_px();
        let legend = self.legend_px();
        let xs = self.series.iter().flat_map(|s| s.xs.iter().copied());
        let ys = self.series.iter().flat_map(|s| s.ys.iter().copied());
        Frame {
            left,
            top,
            width: w - left - legend,
            height: h - top - bottom,
            x_range: limited(&self.x, xs, self.x_min, self.x_max),
            y_range: limited(&self.y, ys, self.y_min, self.y_max),
        }
    }

    /// Render to an SVG document.
    pub fn to_svg(&self) -> String {
        let (w, h) = self.canvas_px();
        let f = self.frame();
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="{FONT_PX}">"#
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="{}">{}</text>"#,
            f.left + f.width / 2.0,
            FONT_PX + 2.0,
            esc(&self.title)
        );
        self.axes(&mut s, &f, h);
        for (i, ser) in self.series.iter().enumerate() {
            let color = ser
                .color
                .clone()
                .unwrap_or_else(|| PALETTE[i % PALETTE.len()].to_string());
            self.line(&mut s, &f, ser, &color);
            legend_row(&mut s, &f, i, ser, &color);
        }
        s.push_str("</svg>\n");
        s
    }
}

/// The axis range of `values` on `scale`, with the limits that are given (data units) in place
/// of the automatic ones; widened where it would be empty.
fn limited(
    scale: &Scale,
    values: impl Iterator<Item = f64>,
    min: Option<f64>,
    max: Option<f64>,
) -> (f64, f64) {
    let (mut lo, mut hi) = scale.range(values);
    if let Some(v) = min.map(|v| scale.to_axis(v)).filter(|v| v.is_finite()) {
        lo = v;
    }
    if let Some(v) = max.map(|v| scale.to_axis(v)).filter(|v| v.is_finite()) {
        hi = v;
    }
    if hi <= lo {
        (lo.min(hi) - 0.5, lo.max(hi) + 0.5)
    } else {
        (lo, hi)
    }
}

/// Row `i` of the legend, right of the plot area.
fn legend_row(s: &mut String, f: &Frame, i: usize, ser: &Series, color: &str) {
    let dash = if ser.dashed {
        r#" stroke-dasharray="6,4""#
    } else {
        ""
    };
    let ly = f.top + 14.0 + LEGEND_ROW_PX * i as f64;
    let lx = f.left + f.width + 12.0;
    let _ = writeln!(
        s,
        r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{color}" stroke-width="2"{dash}/><text x="{}" y="{}">{}</text>"#,
        lx + 22.0,
        lx + 28.0,
        ly + 4.0,
        esc(&ser.name)
    );
}

impl LinePlot {
    /// Write the SVG to `path` atomically ([`atomic_io::write_atomic`]), creating its folder.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        Ok(atomic_io::write_atomic(
            path.as_ref(),
            self.to_svg().as_bytes(),
        )?)
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests;
