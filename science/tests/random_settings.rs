//! Random settings, in and out of their ranges, resolved in-process as `--set KEY=VALUE` over
//! the `tiny` preset: every draw ends, within a bound far above what it takes, in a config that
//! validates again after a round trip through `config.toml`, or in a one-line error naming
//! `--set` or the setting — never a panic or a hang. The cases are capped so that the suite stays fast.

use proptest::prelude::*;
use science::config::{Overrides, RunConfig, RANGES};
use std::sync::mpsc;
use std::time::Duration;

/// A resolution that takes longer than this has hung (it takes milliseconds).
const BOUND: Duration = Duration::from_secs(30);

/// A value for the setting of range `at`: inside, at an edge, or outside (NaN, infinities,
/// zero, negative, absurdly large), as TOML text.
fn value(at: usize, kind: u8, u: f64) -> String {
    let r = &RANGES[at];
    let v = match kind % 10 {
        0 => r.min,
        1 => r.max,
        2 => f64::NAN,
        3 => f64::INFINITY,
        4 => 0.0,
        5 => -1.0,
        6 => 1e30,
        7 => r.max * 10.0 + 1.0,
        _ => r.min + u * (r.max - r.min),
    };
    let integral = v.is_finite() && v.fract() == 0.0 && v.abs() < 9e18;
    let text = if integral && kind.is_multiple_of(2) {
        format!("{}", v as i64)
    } else if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v:?}")
    };
    if r.key.ends_with("[]") {
        format!("[{text}, {text}]")
    } else {
        text
    }
}

/// The dotted key of range `at` as `--set` takes it (`*` a real table key, `[]` dropped).
fn key(at: usize) -> String {
    RANGES[at].key.replace(".*.", ".w.").replace("[]", "")
}

fn resolve(set: Vec<String>) -> Result<RunConfig, String> {
    let o = Overrides {
        preset: Some("tiny".into()),
        set,
        ..Overrides::default()
    };
    RunConfig::resolve_value(&o, None, "quick").map_err(|e| e.to_string())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]
    #[test]
    fn random_settings_end_in_a_valid_config_or_a_one_line_error(
        picks in prop::collection::vec((0..RANGES.len(), any::<u8>(), 0.0f64..1.0), 1..4)
    ) {
        let set: Vec<String> = picks
            .iter()
            .map(|&(at, kind, u)| format!("{}={}", key(at), value(at, kind, u)))
            .collect();
        let (tx, rx) = mpsc::channel();
        let given = set.clone();
        std::thread::spawn(move || {
            let r = std::panic::catch_unwind(|| {
                resolve(given).map(|c| {
                    // What a run writes into config.toml reads back and validates.
                    let back: RunConfig = toml::from_str(&c.to_toml()).expect("reads back");
                    back.validate().map_err(|e| e.to_string())
                })
            });
            let _ = tx.send(r);
        });
        let outcome = rx.recv_timeout(BOUND);
        prop_assert!(outcome.is_ok(), "{set:?}: no answer within {BOUND:?}");
        let outcome = outcome.unwrap();
        prop_assert!(outcome.is_ok(), "{set:?}: panicked");
        match outcome.unwrap() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => prop_assert!(false, "{set:?}: written config invalid: {e}"),
            // A value out of range names `--set KEY`; one that disagrees with another setting
            // names that setting.
            Err(e) => prop_assert!(
                !e.contains('\n') && (e.contains("--set") || e.contains("setting `")),
                "{set:?}: {e}"
            ),
        }
    }
}
