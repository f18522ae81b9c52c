use super::*;
use retina::scene::hue_sphere::HueRule;

fn options(config: Option<PathBuf>) -> Overrides {
    Overrides {
        config,
        ..Overrides::default()
    }
}

#[test]
fn the_checkpoint_budget_applies_during_training_only() {
    let c = RunConfig::preset("quick", "LMS").unwrap();
    let during = c.cmf_settings(false);
    let last = c.cmf_settings(true);
    assert_eq!(
        last, c.cmf_sim,
        "the final measurement uses the full budget"
    );
    assert_eq!(
        (
            during.sets_per_k,
            during.n_test_wavelengths,
            during.location_pairs
        ),
        (
            c.schedule.checkpoint_cmf_sets_per_k,
            c.schedule.checkpoint_cmf_wavelengths,
            c.schedule.checkpoint_cmf_location_pairs
        )
    );
    assert!(during.sets_per_k < last.sets_per_k);
    let tiny = RunConfig::preset("tiny", "LMS").unwrap();
    assert_eq!(tiny.cmf_settings(false), tiny.cmf_sim, "0 means as cmf_sim");
}

#[test]
fn a_typo_in_a_config_file_names_the_file_and_the_field() {
    let dir = std::env::temp_dir().join(format!("cv_cfg_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("typo.toml");
    std::fs::write(
        &path,
        "preset = \"tiny\"\n[cortex.train]\nlearning_rat = 0.01\n",
    )
    .unwrap();
    let err = RunConfig::resolve(&options(Some(path.clone())), "quick")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("typo.toml") && err.contains("learning_rat"),
        "{err}"
    );
    std::fs::write(
        &path,
        "preset = \"tiny\"\nsteps = 7\n[cortex.train]\nlearning_rate = 0.01\n",
    )
    .unwrap();
    let c = RunConfig::resolve(&options(Some(path)), "quick").unwrap();
    assert_eq!(
        (c.steps, c.cortex.train.learning_rate, c.preset.as_str()),
        (7, 0.01, "tiny")
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn command_line_overrides_the_file_and_mismatched_sizes_are_rejected() {
    let mut o = options(None);
    o.preset = Some("tiny".into());
    o.cones = Some("LM".into());
    o.steps = Some(5);
    let c = RunConfig::resolve(&o, "quick").unwrap();
    assert_eq!(
        (c.cones.as_str(), c.retina.cones.as_str(), c.steps),
        ("LM", "LM", 5)
    );
    let mut bad = c.clone();
    bad.cortex.ons_size_px = 64;
    assert!(bad
        .validate()
        .unwrap_err()
        .to_string()
        .contains("ons_size_px"));
}

#[test]
fn every_seed_resolves_to_a_config_that_serialises() {
    for seed in [1, 2, 3, 12345, i64::MAX as u64] {
        let mut o = options(None);
        o.preset = Some("tiny".into());
        o.seed = Some(seed);
        let c = RunConfig::resolve(&o, "quick").unwrap();
        let back: RunConfig = toml::from_str(&c.to_toml()).unwrap();
        assert_eq!(back, c, "seed {seed}");
    }
    let mut o = options(None);
    o.seed = Some(u64::MAX);
    let e = RunConfig::resolve(&o, "quick").unwrap_err().to_string();
    assert!(e.contains("seed"), "{e}");
}

#[test]
fn a_setting_given_with_set_is_laid_over_the_file_and_recorded() {
    let dir = std::env::temp_dir().join(format!("cv_cfg_set_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = "preset = \"tiny\"\n[cortex.train]\nlearning_rate = 0.01\n";
    std::fs::write(dir.join("base.toml"), file).unwrap();
    let mut o = options(Some(dir.join("base.toml")));
    o.set = vec![
        "cortex.train.learning_rate=3e-4".into(),
        "retina.scenes.tiles=5".into(),
    ];
    let c = RunConfig::resolve(&o, "quick").unwrap();
    assert_eq!(
        (c.cortex.train.learning_rate, c.preset.as_str()),
        (3e-4, "tiny")
    );
    assert_eq!(c.retina.scenes.tiles, 5);
    let written: RunConfig = toml::from_str(&c.to_toml()).unwrap();
    assert_eq!(
        written.cortex.train.learning_rate, 3e-4,
        "config.toml holds it"
    );
    // Without a file, and the last of two settings of one key wins.
    let o = Overrides {
        set: vec!["preset=tiny".into(), "steps=9".into(), "steps=7".into()],
        ..Overrides::default()
    };
    let c = RunConfig::resolve(&o, "quick").unwrap();
    assert_eq!(
        (c.preset.as_str(), c.steps, c.cortex.train.steps),
        ("tiny", 7, 7)
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_wrong_setting_given_with_set_names_set_and_the_key() {
    let resolve = |items: &[&str]| {
        let o = Overrides {
            preset: Some("tiny".into()),
            set: items.iter().map(|s| s.to_string()).collect(),
            ..Overrides::default()
        };
        RunConfig::resolve(&o, "quick").unwrap_err().to_string()
    };
    let e = resolve(&["cortex.train.learning_rat=3e-4"]);
    assert!(
        e.starts_with("--set cortex.train.learning_rat=3e-4: ") && e.contains("learning_rat"),
        "{e}"
    );
    // A misspelt key is an error at every depth, in the eye's and CMF-SIM's settings too.
    for typo in [
        "cmf_sim.n_test_wavelenghts=7",
        "cmf_sim.solver.max_iteration=3",
        "retina.cones_per_sid=8",
        "retina.scenes.tile=4",
        "retina.scenes.dead_leaves.size=8",
        "retina.noise.photon_noise=0.1",
        "retina.layout.Foveated.jitter.octave=2",
        "retina.lateral_inhibition.sigma=1",
    ] {
        let e = resolve(&[typo]);
        let key = typo.split('=').next().unwrap().rsplit('.').next().unwrap();
        assert!(
            e.starts_with(&format!("--set {typo}: ")) && e.contains(&format!("`{key}`")),
            "{typo}: {e}"
        );
    }
    let e = resolve(&["steps=many"]);
    assert!(e.starts_with("--set steps=many: "), "{e}");
    let e = resolve(&["cortex.train.learning_rate=-1"]);
    assert!(e.contains("--set cortex.train.learning_rate"), "{e}");
    // A table given key by key: together they make it, one alone names its missing sibling.
    let o = Overrides {
        preset: Some("tiny".into()),
        set: vec![
            "retina.scenes.tetra.environment=HueSphere".into(),
            "retina.scenes.tetra.fraction=0.1".into(),
        ],
        ..Overrides::default()
    };
    let tetra = RunConfig::resolve(&o, "quick").unwrap().retina.scenes.tetra;
    assert_eq!(tetra.map(|t| t.fraction), Some(0.1));
    assert_eq!(tetra.map(|t| t.hue_rule), Some(HueRule::SupportPoint));
    // The hue rule is a third key of the table; it chooses hue-sphere colours only.
    let mut o = o;
    o.set.push("retina.scenes.tetra.hue_rule=max_chroma".into());
    let tetra = RunConfig::resolve(&o, "quick").unwrap().retina.scenes.tetra;
    assert_eq!(tetra.map(|t| t.hue_rule), Some(HueRule::MaxChroma));
    let e = resolve(&[
        "retina.scenes.tetra.environment=Idealised",
        "retina.scenes.tetra.fraction=0.1",
        "retina.scenes.tetra.hue_rule=max_chroma",
    ]);
    assert!(e.contains("scenes.tetra.hue_rule"), "{e}");
    let e = resolve(&["retina.scenes.tetra.environment=HueSphere"]);
    assert!(
        e.starts_with("--set retina.scenes.tetra.environment=HueSphere: ")
            && e.contains("fraction"),
        "{e}"
    );
    let e = resolve(&["learning_rate"]);
    assert!(
        e.starts_with("--set: `learning_rate`: expected KEY=VALUE"),
        "{e}"
    );
}

#[test]
fn a_long_value_is_shortened_in_a_message_and_a_short_one_kept() {
    let long = "C0:400,".repeat(20_000);
    let said = shortened(&format!("setting `--cones`: `{long}`: unknown class"));
    assert!(said.chars().count() < 200, "{said}");
    assert!(said.starts_with("setting `--cones`: `C0:400,") && said.ends_with("unknown class"));
    assert!(
        said.contains(&format!("[{} characters]", long.len() + 3 - 64)),
        "{said}"
    );
    let short = "setting `steps`: 0 must be in [1, 1000000000] (gradient updates)";
    assert_eq!(shortened(short), short);
}

/// With a table given key by key beside a wrong setting, the wrong one is named; a setting
/// whose sibling comes from the `--config` file fits; the file's own mistake names the file.
#[test]
fn the_setting_named_is_the_one_whose_removal_lets_the_rest_parse() {
    let dir = std::env::temp_dir().join(format!("cv_cfg_blame_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let resolve = |file: Option<&str>, items: &[&str]| {
        let config = file.map(|text| {
            std::fs::write(dir.join("f.toml"), text).unwrap();
            dir.join("f.toml")
        });
        let o = Overrides {
            preset: Some("tiny".into()),
            set: items.iter().map(|s| s.to_string()).collect(),
            ..options(config)
        };
        RunConfig::resolve(&o, "quick")
    };
    let tetra = [
        "retina.scenes.tetra.environment=HueSphere",
        "retina.scenes.tetra.fraction=0.1",
    ];
    let e = resolve(None, &[tetra[0], tetra[1], "steps=many"]).unwrap_err();
    assert!(e.to_string().starts_with("--set steps=many: "), "{e}");
    let with_fraction = "[retina.scenes.tetra]\nfraction = 0.2\nenvironment = \"Idealised\"\n";
    let c = resolve(Some(with_fraction), &[tetra[0]]).unwrap();
    assert_eq!(c.retina.scenes.tetra.map(|t| t.fraction), Some(0.2));
    let e = resolve(
        Some("[cortex.train]\nlearning_rat = 0.01\n"),
        &[tetra[0], tetra[1]],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("f.toml") && e.contains("learning_rat"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}
