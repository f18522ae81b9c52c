//! Emergence end to end, the CI version: a `tiny` eye, a `tiny` cortex trained from its optic
//! nerve signal alone (oracle motion, as the `tiny` preset says), then CMF-SIM on the black-box
//! observer "retina + learned cortex". A dichromat retina must end 2-D and a monochromat 1-D.
//!
//! Nothing here is tuned to the expected number: the settings are the `tiny` preset's (CMF-SIM
//! with 20 primary sets per K, 30 test wavelengths, 4 location pairs, the calibrated resolved
//! readout); the dimension is whatever CMF-SIM reports. The dichromat trains 1 500 steps instead
//! of the preset's 300: after 300 its percept still differs more between two retinal locations
//! than it carries colour (CMF-SIM: no colour constancy); after 1 500 and 3 000 it measures 2-D.

use colorvision::run::{run, RunMode};
use science::config::RunConfig;

fn emerged_dimension(cones: &str, steps: u64) -> (usize, String) {
    let mut config = RunConfig::preset("tiny", cones).expect("the tiny preset resolves");
    config.steps = steps;
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
    // The printed verdict in words says the same, beside the paper's figure for the retina.
    let words = colorvision::run::in_words(&out, &summary).expect("CMF-SIM measured");
    assert!(
        words.contains(&format!("{}-dimensional", summary.dimension))
            && words.contains("The paper reports"),
        "{words}"
    );
    // It names the scenes when some tiles came from a richer environment, and only then.
    assert!(!words.contains("of the tiles holding"), "{words}");
    let mut mixed = summary.clone();
    mixed.config.retina.scenes.tetra = Some(retina::scene::pool::TetraMix {
        environment: retina::scene::tetra::TetraEnvironment::HueSphere,
        fraction: 0.1,
        hue_rule: Default::default(),
    });
    let words = colorvision::run::in_words(&out, &mixed).expect("CMF-SIM measured");
    assert!(
        words.contains("10 % of the tiles holding surfaces of the most saturated colour"),
        "{words}"
    );
    std::fs::remove_dir_all(&out).ok();
    (summary.dimension, verdict)
}

#[test]
fn a_dichromat_retina_yields_two_dimensional_colour() {
    let (dimension, verdict) = emerged_dimension("LM", 1500);
    assert_eq!(dimension, 2, "LM (tritanope) retina: {verdict}");
}

#[test]
fn a_monochromat_retina_yields_one_dimensional_colour() {
    let (dimension, verdict) = emerged_dimension("L", 300);
    assert_eq!(dimension, 1, "L monochromat retina: {verdict}");
}
