//! One axis of a [`LinePlot`](super::LinePlot): its data range, linear or log₁₀ scale, and
//! its ticks with their labels.
//!
//! A log axis works in log₁₀ units internally (`to_axis`), is labelled in data units (`0.01`,
//! `100`, `10⁵`), and has unlabelled minor ticks at 2…9 × 10ᵏ when it spans few decades. An
//! integer axis (a count, a dimension) has ticks only at whole numbers; named ticks replace a
//! number by a word (a dimension of 0 drawn as "undefined").

/// How values map to the axis and how it is ticked.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scale {
    /// log₁₀ axis; non-positive values sit on the low edge.
    pub log: bool,
    /// Ticks only at whole numbers (linear axes).
    pub integer: bool,
    /// Labels that replace the number at these tick values (e.g. `0 → "undefined"`).
    pub names: Vec<(f64, String)>,
}

/// A tick: position in axis units, its label (empty for a minor tick).
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    /// Position in axis units (log₁₀ of the value on a log axis).
    pub at: f64,
    /// Text under or beside the tick; empty for minor ticks.
    pub label: String,
}

impl Scale {
    /// A value in axis units: log₁₀ on a log axis (−∞ for non-positive values).
    pub fn to_axis(&self, v: f64) -> f64 {
        match (self.log, v > 0.0) {
            (false, _) => v,
            (true, true) => v.log10(),
            (true, false) => f64::NEG_INFINITY,
        }
    }

    /// The range `[lo, hi]` (axis units) covering `values`, widened where it would be empty;
    /// an integer axis gets a quarter unit beyond its extreme values so points on them are not
    /// drawn on the frame.
    pub fn range(&self, values: impl Iterator<Item = f64>) -> (f64, f64) {
        let (lo, hi) = values
            .map(|v| self.to_axis(v))
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        if !(lo.is_finite() && hi.is_finite()) {
            return (0.0, 1.0);
        }
        if self.integer && !self.log {
            return (lo.floor() - 0.25, hi.ceil() + 0.25);
        }
        if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, hi + 0.5)
        }
    }

    /// Ticks over `[lo, hi]` (axis units), about `n` labelled ones.
    pub fn ticks(&self, lo: f64, hi: f64, n: usize) -> Vec<Tick> {
        let ticks = if self.log {
            log_ticks(lo, hi)
        } else {
            let step = nice_step(lo, hi, n);
            let step = if self.integer {
                step.max(1.0).round()
            } else {
                step
            };
            linear_ticks(lo, hi, step)
        };
        ticks
            .into_iter()
            .map(|mut t| {
                if let Some((_, name)) = self.names.iter().find(|(v, _)| (v - t.at).abs() < 1e-9) {
                    t.label = name.clone();
                }
                t
            })
            .collect()
    }
}

/// The 1, 2 or 5 × 10ᵏ step that gives about `n` intervals over `[lo, hi]`.
fn nice_step(lo: f64, hi: f64, n: usize) -> f64 {
    let raw = (hi - lo) / n.max(1) as f64;
    if !(raw > 0.0) || !raw.is_finite() {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * mag)
}

fn linear_ticks(lo: f64, hi: f64, step: f64) -> Vec<Tick> {
    let (first, last) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
    (first..=last)
        .map(|i| {
            let at = i as f64 * step;
            Tick {
                at,
                label: fmt_number(at),
            }
        })
        .collect()
}

/// "Nice" tick positions (1, 2, 5 × 10ᵏ steps) covering `[lo, hi]`, about `n` of them.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(hi > lo) || !(hi - lo).is_finite() {
        return vec![lo];
    }
    linear_ticks(lo, hi, nice_step(lo, hi, n))
        .into_iter()
        .map(|t| t.at)
        .collect()
}

/// Decades labelled (every other one or sparser past eight decades); over at most three
/// decades 2 × and 5 × 10ᵏ are labelled too, over at most one every m × 10ᵏ, and over at most
/// six the unlabelled ones are minor ticks.
fn log_ticks(lo: f64, hi: f64) -> Vec<Tick> {
    let decades = hi - lo;
    let every = (decades / 8.0).ceil().max(1.0) as i64;
    let mut out = Vec::new();
    for e in (lo.floor() as i64)..=(hi.ceil() as i64) {
        for m in 1..=9 {
            let at = (m as f64).log10() + e as f64;
            if at < lo - 1e-9 || at > hi + 1e-9 {
                continue;
            }
            let labelled = match m {
                1 => e.rem_euclid(every) == 0,
                2 | 5 => decades <= 3.0,
                _ => decades <= 1.0,
            };
            if labelled {
                out.push(Tick {
                    at,
                    label: fmt_power(m, e),
                });
            } else if decades <= 6.0 {
                out.push(Tick {
                    at,
                    label: String::new(),
                });
            }
        }
    }
    out
}

/// `m × 10^e` as a decimal between 0.001 and 10 000, else as `m×10ᵉ` with a superscript.
fn fmt_power(m: u32, e: i64) -> String {
    if (-3..=4).contains(&e) {
        return fmt_number(m as f64 * 10f64.powi(e as i32));
    }
    let sup: String = e
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
        })
        .collect();
    match m {
        1 => format!("10{sup}"),
        _ => format!("{m}×10{sup}"),
    }
}

/// A tick value without trailing zeros (`0.6`, `450`, `2.5e-5` for very small or large ones).
pub fn fmt_number(t: f64) -> String {
    if t == 0.0 {
        "0".into()
    } else if t.abs() >= 1e5 || t.abs() < 1e-3 {
        format!("{t:.1e}")
    } else {
        let s = format!("{t:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(ticks: &[Tick]) -> Vec<&str> {
        ticks
            .iter()
            .filter(|t| !t.label.is_empty())
            .map(|t| t.label.as_str())
            .collect()
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
        assert_eq!(fmt_number(t[3]), "0.6");
    }

    #[test]
    fn an_integer_axis_has_whole_ticks_and_named_ones() {
        let scale = Scale {
            integer: true,
            names: vec![(0.0, "undefined".into())],
            ..Scale::default()
        };
        let (lo, hi) = scale.range([0.0, 3.0, 2.0].into_iter());
        assert_eq!((lo, hi), (-0.25, 3.25));
        let ticks = scale.ticks(lo, hi, 7);
        assert_eq!(labels(&ticks), ["undefined", "1", "2", "3"]);
        let one = scale.range([2.0].into_iter());
        assert_eq!(labels(&scale.ticks(one.0, one.1, 7)), ["2"]);
    }

    #[test]
    fn log_axes_are_labelled_in_data_units() {
        let scale = Scale {
            log: true,
            ..Scale::default()
        };
        let (lo, hi) = scale.range([2e-9, 0.0, 30.0].into_iter());
        assert!(
            (lo - 2e-9f64.log10()).abs() < 1e-12,
            "zero is not in the range"
        );
        let ticks = scale.ticks(lo, hi, 7);
        assert_eq!(
            labels(&ticks),
            ["10⁻⁸", "10⁻⁶", "10⁻⁴", "0.01", "1"],
            "every other decade over ten"
        );
        assert!(ticks.iter().all(|t| !t.label.is_empty()), "no minor ticks");
        let few = scale.ticks(500f64.log10(), 32000f64.log10(), 7);
        assert_eq!(
            labels(&few),
            ["500", "1000", "2000", "5000", "10000", "20000"]
        );
        assert_eq!(few.len(), 6 + 11, "minor ticks between the labelled ones");
        let short = scale.ticks(100f64.log10(), 300f64.log10(), 7);
        assert_eq!(
            labels(&short),
            ["100", "200", "300"],
            "every m × 10ᵏ within a decade"
        );
        assert_eq!(scale.to_axis(-1.0), f64::NEG_INFINITY);
    }
}
