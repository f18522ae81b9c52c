//! Learning rules on the cortex: every built-in rule trains the tiny cortex and is measured
//! against backprop on the same steps; feedback alignment acts only in the buckets it is told;
//! direct feedback alignment reaches every layer of decode with a projection of its own; a
//! bucket with a zero learning-rate factor stays where it starts; and a stateful rule
//! (Kolen–Pollack) resumes from a checkpoint bit-identically.

use cortex::checkpoint::latest_checkpoint;
use cortex::config::CortexConfig;
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{rule, RuleContext, RuleName, RuleSettings, StepStats, Trainer};
use std::path::PathBuf;

fn config() -> CortexConfig {
    let mut c = CortexConfig::tiny();
    c.train.alignment_every_steps = 1;
    c
}

fn source(cfg: &CortexConfig) -> SyntheticSource {
    SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 5))
}

/// A fresh trainer of `cfg` under the rule `name` with `settings` (JSON), drawn from seed 3.
fn trainer(cfg: &CortexConfig, name: &str, settings: &str) -> Trainer {
    let mut t = Trainer::new(cfg.clone()).unwrap();
    let settings: RuleSettings = serde_json::from_str(settings).unwrap();
    let ctx = RuleContext {
        seed: 3,
        start: &t.cortex.params,
    };
    let built = rule::build(&RuleName(name.into()), &settings, &ctx).unwrap();
    t.set_learning_rule(built).unwrap();
    t
}

fn steps(t: &mut Trainer, src: &mut SyntheticSource, k: u64) -> Vec<StepStats> {
    let mut out = Vec::new();
    t.run(src, k, None, |s, _| out.push(s.clone())).unwrap();
    out
}

/// The cosine of bucket `k` (W, C, D, P) in `s`.
fn cosine(s: &StepStats, k: usize) -> f64 {
    s.alignment.unwrap()[k].unwrap().cosine.unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cortex-rules-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn bits(t: &Trainer) -> Vec<Vec<u32>> {
    let p = &t.cortex.params;
    p.ids()
        .map(|id| p.get(id).data().iter().map(|v| v.to_bits()).collect())
        .collect()
}

#[test]
fn every_rule_trains_and_is_measured_against_backprop() {
    let cfg = config();
    for name in rule::BUILT_IN {
        let mut t = trainer(&cfg, name, "{}");
        let stats = steps(&mut t, &mut source(&cfg), 3);
        for s in &stats {
            assert!(s.loss.is_finite(), "{name}: loss {}", s.loss);
            let a = s.alignment.expect("measured every step");
            assert!(
                a.iter().all(Option::is_some),
                "{name}: every bucket measured"
            );
        }
        let d = cosine(&stats[2], 2);
        eprintln!(
            "{name}: cosine to backprop W {:.3} C {:.3} D {d:.3} P {:.3}",
            cosine(&stats[2], 0),
            cosine(&stats[2], 1),
            cosine(&stats[2], 3)
        );
        if name == "backprop" {
            for k in 0..4 {
                let g = stats[2].alignment.unwrap()[k].unwrap();
                assert!(
                    (g.cosine.unwrap() - 1.0).abs() < 1e-9,
                    "backprop against itself"
                );
                assert!((g.rule_norm / g.backprop_norm - 1.0).abs() < 1e-9);
            }
        } else {
            assert!(d < 0.999, "{name}: D's update is backprop's (cosine {d})");
        }
    }
}

#[test]
fn feedback_alignment_acts_only_in_the_buckets_it_is_told() {
    let cfg = config();
    let mut only_p = trainer(&cfg, "feedback-alignment", r#"{"buckets": ["P"]}"#);
    let s = &steps(&mut only_p, &mut source(&cfg), 1)[0];
    // nothing but P's couplings is replaced: D, upstream of P's warp, gets backprop's gradient
    assert!((cosine(s, 2) - 1.0).abs() < 1e-6, "D {}", cosine(s, 2));
    assert!(cosine(s, 3) < 0.999, "P {}", cosine(s, 3));
    let mut only_d = trainer(&cfg, "feedback-alignment", r#"{"buckets": ["D"]}"#);
    let s = &steps(&mut only_d, &mut source(&cfg), 1)[0];
    assert!(cosine(s, 2) < 0.999, "D {}", cosine(s, 2));
    assert!((cosine(s, 3) - 1.0).abs() < 1e-6, "P {}", cosine(s, 3));
}

#[test]
fn direct_feedback_reaches_every_layer_of_decode_with_its_own_projection() {
    let cfg = config();
    let mut t = trainer(&cfg, "direct-feedback-alignment", "{}");
    steps(&mut t, &mut source(&cfg), 1);
    let state = t.learning_rule_state();
    let tags: Vec<&str> = state
        .tensors
        .keys()
        .map(|k| k.split('|').nth(1).unwrap())
        .collect();
    for layer in [
        "inc.conv0",
        "inc.conv1",
        "down1.conv0",
        "down1.conv1",
        "up1.up",
        "up1.conv0",
        "up1.conv1",
        "outc",
    ] {
        assert!(
            tags.contains(&format!("d.{layer}").as_str()),
            "d.{layer} in {tags:?}"
        );
    }
    for w in ["cortex.c.injected", "cortex.w.decoded"] {
        assert!(tags.contains(&w), "{w} in {tags:?}");
    }
    assert_eq!(tags.len(), 10, "{tags:?}");
    for (key, k) in &state.tensors {
        assert!(
            k.dims().len() == 4 && k.dims()[2] == 3,
            "{key}: a 3×3 kernel, {:?}",
            k.dims()
        );
    }
}

#[test]
fn a_bucket_with_a_zero_learning_rate_factor_stays_where_it_starts() {
    let mut cfg = config();
    cfg.train.per_bucket.d.learning_rate_scale = 0.0;
    let mut t = trainer(&cfg, "feedback-alignment", "{}");
    let start = bits(&t);
    steps(&mut t, &mut source(&cfg), 3);
    let p = &t.cortex.params;
    for (id, before) in p.ids().zip(&start) {
        let now: Vec<u32> = p.get(id).data().iter().map(|v| v.to_bits()).collect();
        let name = p.name(id);
        assert_eq!(name.starts_with("d."), &now == before, "{name}");
    }
}

#[test]
fn kolen_pollack_resumes_from_a_checkpoint_bit_identically() {
    let cfg = config();
    let kp = r#"{"learning_rate": 0.05, "weight_decay": 0.01}"#;
    let (k, m) = (3, 3);
    let dir = scratch("kp");

    let mut whole = trainer(&cfg, "kolen-pollack", kp);
    steps(&mut whole, &mut source(&cfg), k + m);

    let mut first = trainer(&cfg, "kolen-pollack", kp);
    let mut src = source(&cfg);
    first.run(&mut src, k, Some(&dir), |_, _| {}).unwrap();
    drop(first);
    let ck = latest_checkpoint(&dir).unwrap().unwrap();
    let mut fresh_src = source(&cfg);
    let mut resumed = Trainer::resume(&ck, Some(&mut fresh_src)).unwrap();
    let settings: RuleSettings = serde_json::from_str(kp).unwrap();
    let start = Trainer::new(cfg.clone()).unwrap();
    let ctx = RuleContext {
        seed: 3,
        start: &start.cortex.params,
    };
    let rebuilt = rule::build(&RuleName("kolen-pollack".into()), &settings, &ctx).unwrap();
    resumed.set_learning_rule(rebuilt).unwrap();
    steps(&mut resumed, &mut fresh_src, m);
    assert!(
        bits(&resumed) == bits(&whole),
        "resumed differs from the unbroken run"
    );

    // The same steps with B started afresh at the interruption differ: the state matters.
    let mut forgetful = trainer(&cfg, "kolen-pollack", kp);
    let mut src = source(&cfg);
    steps(&mut forgetful, &mut src, k);
    let again = rule::build(&RuleName("kolen-pollack".into()), &settings, &ctx).unwrap();
    forgetful.set_learning_rule(again).unwrap();
    steps(&mut forgetful, &mut src, m);
    assert!(bits(&forgetful) != bits(&whole), "the test can fail");
    let _ = std::fs::remove_dir_all(&dir);
}
