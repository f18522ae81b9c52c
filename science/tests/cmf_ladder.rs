//! CMF-SIM's calibration ladder: every rung with a known answer returns it — up to 3-D at the
//! fast (`tiny`) preset's eye and budget, the 4-D rungs at `quick`'s (the 32² eye cannot carry a
//! fourth class) — and the patch-mean readout that the resolved readout replaced fails the
//! identity rung (it finds colour constancy in the raw optic nerve signal).

use science::config::RunConfig;
use science::ladder::{measure_rung, Expected, LADDER};
use science::observer::ReadoutMode;

fn tiny(readout: ReadoutMode) -> RunConfig {
    let mut c = RunConfig::preset("tiny", "LMS").unwrap();
    c.observer.readout = readout;
    c
}

fn four_d(expected: Expected) -> bool {
    matches!(expected, Expected::Dimension(d) if d >= 4)
}

#[test]
fn every_rung_returns_its_known_answer() {
    let quick = RunConfig::preset("quick", "LMS").unwrap();
    let mut wrong = Vec::new();
    for rung in LADDER {
        let config = if four_d(rung.expected) {
            quick.clone()
        } else {
            tiny(ReadoutMode::Resolved)
        };
        // Two location seeds each; one for the 4-D rungs, whose quick eye costs more.
        let seeds: &[u64] = if four_d(rung.expected) { &[0] } else { &[0, 1] };
        for m in measure_rung(&config, rung, seeds).unwrap() {
            if !m.returns(rung.expected) {
                wrong.push(format!(
                    "{} seed {}: dimension {} (no constancy: {}), expected {:?}",
                    rung.name, m.location_seed, m.dimension, m.no_colour_constancy, rung.expected
                ));
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn patch_means_find_constancy_in_the_raw_optic_nerve_signal() {
    let identity = LADDER.iter().find(|r| r.name == "identity").unwrap();
    assert_eq!(identity.expected, Expected::NoConstancy);
    for m in measure_rung(&tiny(ReadoutMode::PatchMean), identity, &[0, 1]).unwrap() {
        assert!(
            !m.no_colour_constancy && m.base_over_energy < 0.5,
            "patch means should hide the mosaic: {m:?}"
        );
    }
}
