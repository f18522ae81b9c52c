//! The gathered table of the dichromats' hue axes (paper §6, Fig. 5.2: the Neural Scope shows a
//! dichromat's percepts along one hue axis — blue–yellow for LS and MS, teal–pink for LM).
//!
//! One row per finished run with two cone classes whose summary holds the Neural Scope's hue axis
//! ([`science::summary::Invariants`]): the axis of the learned percept's colours and, as the known
//! answer, the axis of an ideal dichromat with the same cone classes (a Neural Scope fitted on the
//! true excitation of both classes at every pixel, on the same held-out scenes). Angles are CIELAB
//! hue directions in degrees in [0, 180) ([`colorimetry::HueAxis`]: 90 is yellow–blue, b\*; 0 is
//! red–green, a\*); minor/major is 0 for colours on one line, 1 for no preferred axis.
//!
//! The verdict needs no tolerance: each learned axis is compared with every ideal dichromat's axis
//! in the table, and the nearest (angles differ modulo 180°) must be its own eye's.

use super::Run;
use colorimetry::HueAxis;
use retina::MosaicSpec;

/// A gathered dichromat: its cone classes (`"LM"`), learned axis and ideal axis.
struct Dichromat<'a> {
    run: &'a Run,
    cones: String,
    learned: HueAxis,
    ideal: HueAxis,
}

/// The finished two-class runs whose summaries hold both axes.
fn dichromats(runs: &[Run]) -> Vec<Dichromat<'_>> {
    runs.iter()
        .filter_map(|run| {
            let cones = MosaicSpec::parse(run.settings.get("cones")?).ok()?;
            let classes = cones.class_names();
            if classes.len() != 2 {
                return None;
            }
            let invariants = run.summary.as_ref()?.invariants.as_ref()?;
            Some(Dichromat {
                run,
                cones: classes.concat(),
                learned: invariants.scope_hue_axis?,
                ideal: invariants.ideal_hue_axis?,
            })
        })
        .collect()
}

/// `a − b` for axis directions in degrees, wrapped into (−90, 90].
pub fn axis_difference_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(180.0);
    if d > 90.0 {
        d - 180.0
    } else {
        d
    }
}

/// The cone classes of the ideal dichromat whose axis is nearest `learned_deg` among `ideals`.
fn nearest_ideal<'a>(learned_deg: f64, ideals: &[(&'a str, f64)]) -> Option<&'a str> {
    ideals
        .iter()
        .min_by(|a, b| {
            let da = axis_difference_deg(learned_deg, a.1).abs();
            let db = axis_difference_deg(learned_deg, b.1).abs();
            da.total_cmp(&db)
        })
        .map(|(cones, _)| *cones)
}

/// The Markdown table (empty text when no dichromat was gathered).
pub fn markdown(runs: &[Run]) -> String {
    let found = dichromats(runs);
    if found.is_empty() {
        return String::new();
    }
    // One ideal axis per cone set: the first gathered run's (the same eye on the same scenes
    // gives the same ideal axis).
    let mut ideals: Vec<(&str, f64)> = Vec::new();
    for d in &found {
        if !ideals.iter().any(|(c, _)| *c == d.cones) {
            ideals.push((&d.cones, d.ideal.angle_deg));
        }
    }
    let mut out = String::from(
        // Printed lines of at most 100 columns (each ends in `\n`): the README holds them as printed.
        "Each dichromat's percepts along one hue axis (Neural Scope on held-out scenes, paper \
         Fig. 5.2:\n\
         blue–yellow for LS and MS, teal–pink for LM), beside the known answer: the axis of an \
         ideal\n\
         dichromat with the same cone classes. CIELAB hue directions in degrees (90 = yellow–blue, \
         b\\*;\n\
         0 = red–green, a\\*); minor/major 0 is one line, 1 no axis. The nearest ideal axis must \
         be\n\
         the eye's own.\n\n\
         | run | cones | learned axis | minor/major | ideal dichromat's axis | minor/major | \
         learned − ideal | nearest ideal axis |\n|---|---|---|---|---|---|---|---|\n",
    );
    for d in &found {
        let nearest = nearest_ideal(d.learned.angle_deg, &ideals).unwrap_or("—");
        let verdict = if nearest == d.cones {
            format!("{nearest} (own)")
        } else {
            format!("{nearest} (not its own)")
        };
        out.push_str(&format!(
            "| {} | {} | {:.1}° | {:.2} | {:.1}° | {:.2} | {:+.1}° | {verdict} |\n",
            d.run.folder,
            d.cones,
            d.learned.angle_deg,
            d.learned.minor_to_major,
            d.ideal.angle_deg,
            d.ideal.minor_to_major,
            axis_difference_deg(d.learned.angle_deg, d.ideal.angle_deg),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(angle_deg: f64) -> HueAxis {
        HueAxis {
            angle_deg,
            minor_to_major: 0.1,
            rms_chroma: 20.0,
        }
    }

    /// A finished run of `cones` whose Neural Scope found `learned` and its ideal `ideal` (the
    /// rest of its summary is a recorded dichromat's).
    fn run(folder: &str, cones: &str, learned: Option<f64>, ideal: f64) -> Run {
        crate::gather::recorded_run(folder, cones, "LS-24k", |summary| {
            let invariants = summary.invariants.as_mut().unwrap();
            invariants.scope_hue_axis = learned.map(axis);
            invariants.ideal_hue_axis = Some(axis(ideal));
        })
    }

    #[test]
    fn axis_differences_wrap_at_half_a_turn() {
        assert_eq!(axis_difference_deg(59.0, 57.0), 2.0);
        assert_eq!(axis_difference_deg(57.0, 59.0), -2.0);
        assert_eq!(axis_difference_deg(175.0, 5.0), -10.0);
        assert_eq!(axis_difference_deg(5.0, 175.0), 10.0);
        assert_eq!(axis_difference_deg(90.0, 0.0), 90.0);
    }

    #[test]
    fn each_dichromat_is_judged_against_every_ideal_axis() {
        let runs = [
            run("lm", "LM", Some(59.0), 57.0),
            run("ls", "LS", Some(101.0), 99.0),
            // Learned nearer LS's ideal than its own: the verdict must say so.
            run("ms", "MS", Some(98.0), 109.0),
            run("mono", "L", Some(118.0), 118.0),
            run("tri", "LMS", Some(139.0), 139.0),
        ];
        let md = markdown(&runs);
        assert!(
            md.contains("| lm | LM | 59.0° | 0.10 | 57.0° | 0.10 | +2.0° | LM (own) |"),
            "{md}"
        );
        assert!(md.contains("| ls | LS | 101.0° |"), "{md}");
        assert!(md.contains("| -11.0° | LS (not its own) |"), "{md}");
        assert!(!md.contains("| mono |") && !md.contains("| tri |"), "{md}");
        assert_eq!(
            md.lines().filter(|l| l.starts_with("| ")).count(),
            4,
            "{md}"
        );
    }

    #[test]
    fn a_dichromat_whose_scope_found_no_axis_gets_no_row_and_none_no_table() {
        let runs = [run("flat", "LS", None, 99.0)];
        assert_eq!(markdown(&runs), "");
        assert_eq!(markdown(&[run("mono", "L", Some(10.0), 10.0)]), "");
    }
}
