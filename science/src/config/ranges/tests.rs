use super::super::{Overrides, PRESETS};
use super::*;

/// Settings absent from every preset (optional fields, the tetrachromatic tiles), each set to
/// a valid value so that the walk sees it.
const OPTIONAL: &[&str] = &[
    "cortex.p.log_scale_bound=2.0",
    "cortex.train.clip_global_norm=1.0",
    "cortex.train.alignment_every_steps=10",
    "cortex.train.sgd_momentum=0.5",
    "cortex.loss.outside_field_weight=1.0",
    "cortex.train.per_bucket.w.clip_norm=1.0",
    "cortex.train.per_bucket.c.clip_norm=1.0",
    "cortex.train.per_bucket.d.clip_norm=1.0",
    "cortex.train.per_bucket.p.clip_norm=1.0",
    "cmf_sim.intensity=1.0",
    "observer.edge_clearance_cones=2.0",
    "retina.scenes.tetra={ environment = \"HueSphere\", fraction = 0.1 }",
];

fn resolved(preset: &str, set: &[&str]) -> Result<RunConfig, ConfigError> {
    let o = Overrides {
        preset: Some(preset.into()),
        set: set.iter().map(|s| s.to_string()).collect(),
        ..Overrides::default()
    };
    RunConfig::resolve_value(&o, None, "quick")
}

/// Every preset, plain and with every optional setting given, as TOML.
fn every_config() -> Vec<toml::Value> {
    let mut out = Vec::new();
    for preset in PRESETS {
        for set in [&[][..], OPTIONAL] {
            let c = resolved(preset, set).unwrap_or_else(|e| panic!("{preset}: {e}"));
            out.push(toml::Value::try_from(&c).unwrap());
        }
    }
    out
}

#[test]
fn every_numeric_field_of_every_preset_has_a_range_and_every_range_a_field() {
    let mut used = vec![false; RANGES.len()];
    let mut missing = Vec::new();
    for value in every_config() {
        let fields = numeric_fields(&value);
        assert!(fields.len() > 100, "the walk found {} fields", fields.len());
        for (path, _) in fields {
            let parts: Vec<&str> = path.iter().map(String::as_str).collect();
            match range_of(&parts) {
                Some(r) => used[RANGES.iter().position(|x| x.key == r.key).unwrap()] = true,
                None => missing.push(path.join(".")),
            }
        }
    }
    missing.sort();
    missing.dedup();
    assert!(
        missing.is_empty(),
        "numeric settings without a range: {missing:?}"
    );
    let stale: Vec<&str> = RANGES
        .iter()
        .zip(&used)
        .filter(|(_, &u)| !u)
        .map(|(r, _)| r.key)
        .collect();
    assert!(stale.is_empty(), "ranges of no setting: {stale:?}");
}

#[test]
fn every_range_is_well_formed() {
    for r in RANGES {
        assert!(
            r.min.is_finite() && r.max.is_finite() && r.min < r.max,
            "{}",
            r.key
        );
        assert!(!r.what.is_empty(), "{}", r.key);
    }
    let mut keys: Vec<&str> = RANGES.iter().map(|r| r.key).collect();
    keys.sort_unstable();
    let n = keys.len();
    keys.dedup();
    assert_eq!(keys.len(), n, "a key listed twice");
}

#[test]
fn every_recorded_run_config_still_validates() {
    let results = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../results");
    let mut checked = 0;
    for entry in std::fs::read_dir(&results).unwrap() {
        let path = entry.unwrap().path().join("config.toml");
        if !path.is_file() {
            continue;
        }
        let mut value: toml::Value =
            toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        // A baseline measured without training is recorded with no steps; it is not a
        // setting to run again, and its other settings must still be in range.
        if value["cortex"].get("baseline").and_then(|b| b.as_str()) == Some("identity_percept") {
            super::super::set_dotted(&mut value, "steps", toml::Value::Integer(1));
            super::super::set_dotted(&mut value, "cortex.train.steps", toml::Value::Integer(1));
        }
        // A whole config is validated as its run reads it (alone: laid over today's preset, a
        // record that predates a setting is refused, `super::super::unnamed`); a subset is
        // resolved over the preset.
        let checked_alone = match value.clone().try_into::<RunConfig>() {
            Ok(alone) => alone.validate(),
            Err(_) => {
                let file = Some((path.display().to_string(), value));
                RunConfig::resolve_value(&Overrides::default(), file, "quick").map(|_| ())
            }
        };
        if let Err(e) = checked_alone {
            panic!("{}: {e}", path.display());
        }
        checked += 1;
    }
    assert!(checked >= 50, "only {checked} recorded configs");
}

#[test]
fn meaningless_values_are_refused_naming_the_field() {
    for (set, field) in [
        (
            "retina.noise.photon_noise_scale=nan",
            "retina.noise.photon_noise_scale",
        ),
        (
            "retina.noise.li_noise_scale=1e30",
            "retina.noise.li_noise_scale",
        ),
        (
            "retina.layout.Foveated.density.peak_density_per_deg2=0",
            "peak_density_per_deg2",
        ),
        (
            "retina.layout.Foveated.jitter.amplitude_cells=1e9",
            "amplitude_cells",
        ),
        (
            "retina.template.optical_density=nan",
            "retina.template.optical_density",
        ),
        ("retina.grid.step_nm=0.0001", "retina.grid.step_nm"),
        ("retina.grid.step_nm=1e30", "retina.grid.step_nm"),
        ("retina.scenes.dead_leaves.max_aspect=1e30", "max_aspect"),
        ("retina.scenes.tiles=1000000000", "retina.scenes.tiles"),
        ("retina.scenes.tile_px=1000000000", "retina.scenes.tile_px"),
        (
            "cmf_sim.n_test_wavelengths=1000000000",
            "cmf_sim.n_test_wavelengths",
        ),
        ("cmf_sim.location_pairs=100000", "cmf_sim.location_pairs"),
        ("schedule.eval_batches=1000000000", "schedule.eval_batches"),
        ("cortex.train.adam_eps=0", "cortex.train.adam_eps"),
        (
            "cmf_sim.test_range_nm=[400.0, inf]",
            "cmf_sim.test_range_nm",
        ),
    ] {
        let e = resolved("tiny", &[set]).unwrap_err().to_string();
        let key = set.split('=').next().unwrap();
        assert!(
            e.contains(&format!("--set {key}")) && e.contains(field) && !e.contains('\n'),
            "{set}: {e}"
        );
    }
}

#[test]
fn the_edges_of_a_range_are_valid_and_beyond_them_not() {
    assert!(resolved("tiny", &["retina.grid.step_nm=1.0"]).is_ok());
    assert!(resolved("tiny", &["retina.grid.step_nm=0.999"]).is_err());
    assert!(resolved("tiny", &["retina.noise.photon_noise_scale=0.0"]).is_ok());
    assert!(resolved("tiny", &["cortex.train.learning_rate=0.0"]).is_err());
    assert!(resolved("tiny", &["cortex.train.learning_rate=10.0"]).is_ok());
}

#[test]
fn a_primary_separation_wider_than_a_band_is_refused_as_cmf_sim_refuses_it() {
    let e = resolved("tiny", &["cmf_sim.min_primary_separation_nm=500"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("--set cmf_sim.min_primary_separation_nm"), "{e}");
    assert!(e.contains("bands"), "{e}");
}
