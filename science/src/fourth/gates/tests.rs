//! Gate 1 on the test eye (`tiny`, 32² cones), on cases whose answer is known.

use super::*;

fn gate(cones: &str, scenes: GateScenes, q_from_lms: Option<QFromLms>) -> GateRow {
    let case = GateCase {
        cones: cones.into(),
        scenes,
        white_balance: true,
        q_from_lms,
    };
    measure_gate(&RetinaConfig::tiny(), &case, 8, 1).unwrap()
}

#[test]
fn a_fourth_kind_in_the_span_of_l_and_m_has_no_own_signal() {
    let row = gate("LMS+M_coexpress_L", GateScenes::Natural, None);
    assert!(
        row.own.within < 1e-9 && row.own.across < 1e-9,
        "{:?}",
        row.own
    );
    assert!(row.ons_own_over_noise < 1e-9, "{row:?}");
    assert!(
        row.demosaic_var > 0.0 && row.photon_noise_var > 0.0,
        "{row:?}"
    );
}

#[test]
fn q_replaced_after_the_balance_has_no_own_signal_before_it_has_some_across() {
    let after = gate(
        "LMSQ,Q:506",
        GateScenes::Natural,
        Some(QFromLms::AfterBalance),
    );
    assert!(
        after.own.within < 1e-6 && after.own.across < 1e-6,
        "{:?}",
        after.own
    );
    let before = gate(
        "LMSQ,Q:506",
        GateScenes::Natural,
        Some(QFromLms::BeforeBalance),
    );
    assert!(before.own.within < 1e-6, "{:?}", before.own);
    assert!(
        before.own.across > 10.0 * after.own.across,
        "{:?}",
        before.own
    );
}

#[test]
fn idealised_tiles_give_q_much_of_its_own() {
    let natural = gate("LMSQ,Q:506", GateScenes::Natural, None);
    let ideal = gate("LMSQ,Q:506", GateScenes::Idealised, None);
    assert!(
        ideal.own.across > 0.2 && ideal.own.within > 0.2,
        "{:?}",
        ideal.own
    );
    assert!(natural.own.across < ideal.own.across, "{:?}", natural.own);
    assert!(ideal.ons_own_over_noise > natural.ons_own_over_noise);
}

#[test]
fn the_noise_ratios_mean_square_is_the_eyes() {
    let noise = retina::cones::NoiseConfig::default();
    // r = k/10, k uniform in 0..=10: E[r²] = 385 / 100 / 11.
    assert!((mean_r_squared(&noise) - 0.35).abs() < 1e-12);
    assert_eq!(mean_r_squared(&retina::cones::NoiseConfig::off()), 0.0);
}

#[test]
fn the_table_has_every_cone_set_scene_and_balance_and_the_controls() {
    let cases = gate_cases();
    assert_eq!(cases.len(), 3 * GateScenes::ALL.len() * 2 + 6);
    assert_eq!(GateScenes::ALL.len(), 9);
    // The max-chroma sources draw their tiles by that rule, and only they.
    for scenes in GateScenes::ALL {
        let rule = scenes.tetra().map(|t| t.hue_rule).unwrap_or_default();
        let named = scenes.name().contains("max chroma");
        assert_eq!(rule == HueRule::MaxChroma, named, "{}", scenes.name());
    }
    assert!(cases
        .iter()
        .filter(|c| c.q_from_lms.is_some())
        .all(|c| c.cones == "LMSQ,Q:506" && c.white_balance));
}
