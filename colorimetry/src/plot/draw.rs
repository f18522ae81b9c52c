//! Drawing one [`LinePlot`] into SVG: the axes (grid, ticks, labels, frame) and each series'
//! line, markers and dash, in the pixel frame that the parent module lays out.

use super::*;

impl LinePlot {
    /// Grid lines, ticks, tick labels, the frame and the axis labels.
    pub(super) fn axes(&self, s: &mut String, f: &Frame, canvas_h: f64) {
        let (bottom, right) = (f.top + f.height, f.left + f.width);
        for t in self.x.ticks(f.x_range.0, f.x_range.1, 8) {
            let x = f.px(t.at);
            let (stroke, y_end) = match t.label.is_empty() {
                true => ("#f2f2f2", bottom),
                false => ("#e5e5e5", bottom + 4.0),
            };
            let _ = writeln!(
                s,
                r#"<line x1="{x:.1}" y1="{}" x2="{x:.1}" y2="{y_end}" stroke="{stroke}"/><text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"#,
                f.top,
                bottom + 17.0,
                esc(&t.label)
            );
        }
        for t in self.y.ticks(f.y_range.0, f.y_range.1, 7) {
            let y = f.py(t.at);
            let stroke = if t.label.is_empty() {
                "#f2f2f2"
            } else {
                "#e5e5e5"
            };
            let _ = writeln!(
                s,
                r#"<line x1="{}" y1="{y:.1}" x2="{right}" y2="{y:.1}" stroke="{stroke}"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"#,
                f.left - 4.0,
                f.left - 6.0,
                y + 4.0,
                esc(&t.label)
            );
        }
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#333"/>"##,
            f.left, f.top, f.width, f.height
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            f.left + f.width / 2.0,
            canvas_h - 12.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate(18,{}) rotate(-90)" text-anchor="middle">{}</text>"#,
            f.top + f.height / 2.0,
            esc(&self.y_label)
        );
    }

    /// The series' path (and markers) in plot coordinates.
    pub(super) fn line(&self, s: &mut String, f: &Frame, ser: &Series, color: &str) {
        let dash = if ser.dashed {
            r#" stroke-dasharray="6,4""#
        } else {
            ""
        };
        let mut d = String::new();
        let mut dots = String::new();
        let mut pen: Option<(f64, f64)> = None;
        for (&x, &y) in ser.xs.iter().zip(&ser.ys) {
            let mut ty = self.y.to_axis(y);
            if self.y.log && ty == f64::NEG_INFINITY {
                ty = f.y_range.0;
            }
            let tx = self.x.to_axis(x);
            if !(tx.is_finite() && ty.is_finite()) {
                pen = None;
                continue;
            }
            let (px, py) = (f.px(tx), f.py(ty));
            let _ = match pen {
                None => write!(d, "M{px:.2},{py:.2} "),
                Some(_) if ser.steps => write!(d, "H{px:.2} V{py:.2} "),
                Some(_) => write!(d, "L{px:.2},{py:.2} "),
            };
            if ser.markers {
                let _ = write!(
                    dots,
                    r#"<circle cx="{px:.2}" cy="{py:.2}" r="3.5" fill="{color}"/>"#
                );
            }
            pen = Some((px, py));
        }
        let _ = writeln!(
            s,
            r#"<path d="{d}" fill="none" stroke="{color}" stroke-width="1.6"{dash}/>{dots}"#
        );
    }
}
