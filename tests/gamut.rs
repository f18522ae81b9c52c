//! `colorvision gamut` on the real eye: the CMF-SIM test lights against the colours of the
//! training scenes. Known answer: natural scenes under daylight hold no colour that excites the
//! S cones alone, so the shortest-wavelength lights lie far from every scene colour, while a
//! light near the middle of the spectrum (L and M together, as in most surfaces) does not; scenes
//! whose cone classes vary independently hold every light.

mod common;

use common::{colorvision, text};

#[test]
fn short_wavelength_lights_lie_beyond_the_scenes_and_mid_spectrum_ones_do_not() {
    let dir = std::env::temp_dir().join(format!("cv_gamut_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let o = colorvision(&dir, &["gamut", "--preset", "tiny", "--out", "g"]);
    assert!(o.status.success(), "{}", text(&o));
    let g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("g/gamut.json")).unwrap()).unwrap();
    let wl: Vec<f64> = serde_json::from_value(g["wavelengths_nm"].clone()).unwrap();
    let nearest: Vec<f64> = serde_json::from_value(g["nearest_deg"].clone()).unwrap();
    assert_eq!(wl.len(), nearest.len());
    let at = |nm: f64| {
        let i = wl
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - nm).abs().total_cmp(&(b.1 - nm).abs()))
            .unwrap()
            .0;
        nearest[i]
    };
    assert!(at(420.0) > 10.0, "420 nm is {}° from the scenes", at(420.0));
    assert!(at(570.0) < 5.0, "570 nm is {}° from the scenes", at(570.0));
    assert!(
        text(&o).contains("more than 10° from every scene colour: 400"),
        "{}",
        text(&o)
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn scenes_whose_cone_classes_vary_independently_hold_every_test_light() {
    // Known answer: in S-07's idealised environment each class's excitation is drawn on its own,
    // so every direction of the positive octant, every test light's among them, is some
    // patch's colour. With every tile idealised, no light may lie beyond the scenes.
    let dir = std::env::temp_dir().join(format!("cv_gamut_idealised_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("idealised.toml"),
        "preset = \"tiny\"\n[retina.scenes.tetra]\nenvironment = \"Idealised\"\nfraction = 1.0\n",
    )
    .unwrap();
    let o = colorvision(&dir, &["gamut", "--config", "idealised.toml", "--out", "g"]);
    assert!(o.status.success(), "{}", text(&o));
    let g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("g/gamut.json")).unwrap()).unwrap();
    let nearest: Vec<f64> = serde_json::from_value(g["nearest_deg"].clone()).unwrap();
    let worst = nearest.iter().copied().fold(0.0, f64::max);
    assert!(
        worst < 5.0,
        "a test light is {worst}° from every idealised colour"
    );
    assert!(
        text(&o).contains("more than 10° from every scene colour: none"),
        "{}",
        text(&o)
    );
    std::fs::remove_dir_all(dir).ok();
}
