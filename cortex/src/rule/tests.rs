use super::builtin::NoSettings;
use super::*;
use autodiff::learn::Backprop;

fn settings(json: &str) -> RuleSettings {
    serde_json::from_str(json).unwrap()
}

fn name(n: &str) -> RuleName {
    RuleName(n.into())
}

#[test]
fn built_in_rules_are_registered_and_an_unknown_name_lists_them() {
    let names: Vec<String> = registered().into_iter().map(|(n, _)| n).collect();
    for n in [
        "backprop",
        "feedback-alignment",
        "kolen-pollack",
        "direct-feedback-alignment",
        "forward-forward",
    ] {
        assert!(names.iter().any(|x| x == n), "{n} in {names:?}");
        check(&name(n), &RuleSettings::new()).unwrap();
    }
    let e = check(&name("hebb"), &RuleSettings::new())
        .unwrap_err()
        .to_string();
    assert!(e.contains("learning_rule") && e.contains("\"hebb\""), "{e}");
    for n in &names {
        assert!(e.contains(n.as_str()), "{e}");
    }
}

#[test]
fn a_setting_a_rule_does_not_have_or_cannot_use_is_an_error_naming_it() {
    let fa = name("feedback-alignment");
    check(
        &fa,
        &settings(r#"{"scheme": "frsf", "buckets": ["D", "w"]}"#),
    )
    .unwrap();
    let e = check(&fa, &settings(r#"{"schem": "frsf"}"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("schem") && e.contains("rule"), "{e}");
    let e = check(&fa, &settings(r#"{"scheme": "sign"}"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("sign") && e.contains("usf"), "{e}");
    let e = check(&fa, &settings(r#"{"buckets": ["C"]}"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("\"C\"") && e.contains("normalised"), "{e}");
    let dfa = name("direct-feedback-alignment");
    let e = check(&dfa, &settings(r#"{"buckets": ["P"]}"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("output mapping"), "{e}");
    let e = check(&dfa, &settings(r#"{"kernel_px": 4}"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("odd"), "{e}");
    let e = check(&name("backprop"), &settings(r#"{"scheme": "usf"}"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("scheme"), "{e}");
}

#[test]
fn a_rule_registered_from_outside_is_built_by_name() {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Halved {
        factor: f64,
    }
    register(RuleEntry::new(
        "test-registered-rule",
        "backprop, for the registry's test",
        |s: Halved, _| {
            assert_eq!(s.factor, 0.5);
            Box::new(Backprop)
        },
    ))
    .unwrap();
    let n = name("test-registered-rule");
    let start = ParamStore::new();
    let ctx = RuleContext {
        seed: 1,
        start: &start,
    };
    build(&n, &settings(r#"{"factor": 0.5}"#), &ctx).unwrap();
    assert!(
        check(&n, &RuleSettings::new()).is_err(),
        "factor is required"
    );
    assert!(describe(&n, &settings(r#"{"factor": 0.5}"#)).contains("for the registry's test"));
    let again = RuleEntry::new("test-registered-rule", "", |_: NoSettings, _| {
        Box::new(Backprop)
    });
    assert!(register(again).unwrap_err().to_string().contains("already"));
    let bad = RuleEntry::new("Not Kebab", "", |_: NoSettings, _| Box::new(Backprop));
    assert!(register(bad).unwrap_err().to_string().contains("kebab"));
}

#[test]
fn feedback_seed_separates_the_draw_from_the_run_seed() {
    let start = ParamStore::new();
    let ctx = RuleContext {
        seed: 3,
        start: &start,
    };
    assert_eq!(ctx.draw_seed(None), 3 ^ 0xFA);
    assert_eq!(ctx.draw_seed(Some(1)), 1 ^ 0xFA);
}
