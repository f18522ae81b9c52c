//! `colorvision experiment tetrachromats` end to end on the `tiny` eye for two steps: each of the
//! two tetrachromat observers is trained in each of the paper's three environments (S-07), one
//! run folder each, and each folder records the environment it was trained in. What the
//! environments contain is tested in `retina::scene` (hue sphere, idealised patches).

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_colorvision");

fn setting<'a>(config: &'a toml::Value, path: &[&str]) -> Option<&'a toml::Value> {
    path.iter().try_fold(config, |v, key| v.get(key))
}

#[test]
fn tetrachromats_trains_both_observers_in_three_environments() {
    let out = std::env::temp_dir().join(format!("cv_tetrachromats_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = Command::new(BIN)
        .args([
            "experiment",
            "tetrachromats",
            "--preset",
            "tiny",
            "--steps",
            "2",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .expect("the binary runs");
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    for (observer, cones) in [("LMSQ_Q_506", "LMSQ,Q:506"), ("LMSQ", "LMSQ")] {
        // The hue-sphere tiles a tenth (the paper's 100 patches beside 900 images), the
        // idealised tiles half (the share the human-Q A/B found:
        // experiments::IDEALISED_TILE_FRACTION).
        for (environment, recorded, share) in [
            ("natural", None, None),
            ("hue_sphere", Some("HueSphere"), Some(0.1)),
            ("idealised", Some("Idealised"), Some(0.5)),
        ] {
            let dir = out.join(observer).join(environment);
            let read = |name: &str| {
                std::fs::read_to_string(dir.join(name))
                    .unwrap_or_else(|e| panic!("{}: {e}", dir.join(name).display()))
            };
            let summary: serde_json::Value = serde_json::from_str(&read("summary.json")).unwrap();
            assert_eq!(summary["steps"].as_u64(), Some(2), "{}", dir.display());
            let config: toml::Value = toml::from_str(&read("config.toml")).unwrap();
            assert_eq!(
                setting(&config, &["retina", "cones"]).and_then(|v| v.as_str()),
                Some(cones)
            );
            let tetra = setting(&config, &["retina", "scenes", "tetra"]);
            assert_eq!(
                tetra
                    .and_then(|t| t.get("environment"))
                    .and_then(|v| v.as_str()),
                recorded,
                "{}",
                dir.display()
            );
            let fraction = tetra
                .and_then(|t| t.get("fraction"))
                .and_then(|v| v.as_float());
            assert_eq!(fraction, share, "{}: the share of tiles", dir.display());
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}
