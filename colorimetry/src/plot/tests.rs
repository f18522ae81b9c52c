//! Tests of the SVG line plot: one path per series, log axes, legend placement, step series and named ticks.

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
    p.y.log = true;
    p.push(Series::new("s", vec![0.0, 1.0, 2.0], vec![1e-3, 0.0, 10.0]));
    let svg = p.to_svg();
    assert!(svg.contains(">0.001<") && svg.contains(">10<"));
    assert!(!svg.contains("NaN") && !svg.contains("inf"));
}

/// The x of every `<text x=…>` element and its text.
fn texts(svg: &str) -> Vec<(f64, String)> {
    svg.split("<text x=\"")
        .skip(1)
        .map(|rest| {
            let x: f64 = rest[..rest.find('"').unwrap()].parse().unwrap();
            let body = &rest[rest.find('>').unwrap() + 1..rest.find("</text>").unwrap()];
            (x, body.to_string())
        })
        .collect()
}

#[test]
fn legend_labels_end_inside_the_canvas() {
    let mut p = LinePlot::new("t", "x", "y");
    let long = "pass threshold (1× base) of a rather long legend entry, area 1.234e-5";
    p.push(Series::new(long, vec![0.0, 1.0], vec![1.0, 2.0]));
    p.push(Series::new("short", vec![0.0, 1.0], vec![2.0, 1.0]));
    let (width, _) = p.canvas_px();
    assert!(width > p.width_px, "the canvas widens for a long label");
    let svg = p.to_svg();
    let (x, text) = texts(&svg).into_iter().find(|(_, t)| t == long).unwrap();
    let end = x + text.chars().count() as f64 * CHAR_PX;
    assert!(
        end <= width,
        "legend text ends at {end} px, canvas {width} px"
    );
    let many = (0..40).fold(LinePlot::new("t", "x", "y"), |mut p, i| {
        p.push(Series::new(format!("s{i}"), vec![0.0], vec![0.0]));
        p
    });
    assert!(
        many.canvas_px().1 > many.height_px,
        "the canvas grows for many rows"
    );
}

#[test]
fn a_step_series_holds_each_value_and_marks_each_point() {
    let mut p = LinePlot::new("dimension", "step", "dimension");
    p.y.integer = true;
    p.push(Series::new("d", vec![0.0, 10.0, 20.0], vec![1.0, 2.0, 3.0]).steps());
    let svg = p.to_svg();
    let path = svg.split("<path d=\"").nth(1).unwrap();
    let path = &path[..path.find('"').unwrap()];
    assert_eq!(path.matches('H').count(), 2, "{path}");
    assert_eq!(path.matches('V').count(), 2, "{path}");
    assert!(!path.contains('L'), "no sloped segments: {path}");
    assert_eq!(svg.matches("<circle").count(), 3);
    let mut one = LinePlot::new("one point", "step", "dimension");
    one.push(Series::new("d", vec![5.0], vec![2.0]).steps());
    assert_eq!(
        one.to_svg().matches("<circle").count(),
        1,
        "a single point shows"
    );
}

#[test]
fn a_named_tick_replaces_its_number() {
    let mut p = LinePlot::new("dimension", "step", "dimension");
    p.y = Scale {
        integer: true,
        names: vec![(0.0, "undefined".into())],
        ..Scale::default()
    };
    p.push(Series::new("d", vec![0.0, 10.0], vec![0.0, 2.0]).steps());
    let y_tick_x = MARGIN_PX[0] - 6.0;
    let labels: Vec<String> = texts(&p.to_svg())
        .into_iter()
        .filter(|&(x, _)| x == y_tick_x)
        .map(|(_, t)| t)
        .collect();
    assert!(labels.iter().any(|t| t == "undefined"));
    assert_eq!(labels, ["undefined", "1", "2"]);
}
