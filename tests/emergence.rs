//! Emergence end to end, the CI version: a `tiny` eye, a `tiny` cortex trained from its optic
//! nerve signal alone (oracle motion, as the `tiny` preset says), then CMF-SIM on the black-box
//! observer "retina + learned cortex". A dichromat retina must end 2-D and a monochromat 1-D.
//!
//! Nothing here is tuned to the expected number: the settings are the `tiny` preset's (300
//! steps, CMF-SIM with 8 primary sets per K, 30 test wavelengths, 2 location pairs); the
//! dimension is whatever CMF-SIM reports.

use colorvision::config::RunConfig;
use colorvision::run::{run, RunMode};

fn emerged_dimension(cones: &str) -> (usize, String) {
    let config = RunConfig::preset("tiny", cones).expect("the tiny preset resolves");
    let out = std::env::temp_dir().join(format!(
        "colorvision_emergence_{cones}_{}",
        std::process::id()
    ));
    let summary = run(
        &config,
        &out,
        RunMode {
            cmf_sim: true,
            pictures: false,
            progress: false,
        },
    )
    .expect("the run completes");
    let verdict = format!(
        "{} after {} steps; held-out prediction {:?}",
        summary.verdict, summary.steps, summary.heldout_prediction
    );
    let written: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).expect("summary.json written"),
    )
    .expect("valid JSON");
    assert_eq!(
        written["dimension"].as_u64(),
        Some(summary.dimension as u64),
        "summary.json carries the dimension"
    );
    std::fs::remove_dir_all(&out).ok();
    (summary.dimension, verdict)
}

#[test]
fn a_dichromat_retina_yields_two_dimensional_colour() {
    let (dimension, verdict) = emerged_dimension("LM");
    assert_eq!(dimension, 2, "LM (tritanope) retina: {verdict}");
}

#[test]
fn a_monochromat_retina_yields_one_dimensional_colour() {
    let (dimension, verdict) = emerged_dimension("L");
    assert_eq!(dimension, 1, "L monochromat retina: {verdict}");
}
