//! The structural proof that the cortex learns from the optic nerve alone:
//! its manifest has no `retina` dependency, and the training input carries ONS and optional
//! oracle motion only.

#[test]
fn cortex_manifest_has_no_retina_dependency() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml")).unwrap();
    let manifest: toml::Value = toml::from_str(&text).unwrap();
    for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
        if let Some(deps) = manifest.get(table).and_then(|t| t.as_table()) {
            for (name, spec) in deps {
                assert_ne!(
                    name, "retina",
                    "cortex/Cargo.toml [{table}] depends on retina"
                );
                let s = spec.to_string();
                assert!(
                    !s.contains("retina"),
                    "cortex/Cargo.toml [{table}] {name} = {s} points at the retina"
                );
            }
        }
    }
}

#[test]
fn the_batch_crate_depends_on_nothing() {
    // The one batch type lives in `optic_nerve`, which both the eye and the cortex use: it must
    // not become a way back to the retina.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../optic_nerve/Cargo.toml");
    let manifest: toml::Value = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    for table in ["dependencies", "dev-dependencies", "build-dependencies"] {
        let deps = manifest.get(table).and_then(|t| t.as_table());
        assert!(
            deps.is_none_or(|d| d.is_empty()),
            "optic_nerve/Cargo.toml [{table}] is not empty: {deps:?}"
        );
    }
}

#[test]
fn training_batch_carries_only_ons_and_optional_motion() {
    // Exhaustive destructuring: adding a field to OnsBatch breaks this test on purpose.
    let b = cortex::OnsBatch {
        ons: vec![0.0; 2 * 16],
        batch: 1,
        n: 4,
        oracle_motion: None,
    };
    let cortex::OnsBatch {
        ons,
        batch,
        n,
        oracle_motion,
    } = b;
    assert_eq!((ons.len(), batch, n, oracle_motion), (32, 1, 4, None));
}
