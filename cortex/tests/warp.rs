//! Bucket identities and the warp.

use autodiff::{Tape, Tensor};
use cortex::buckets::m::sampling::{bilinear, nearest_inside, unit_grid};
use cortex::config::{CortexConfig, PMode};
use cortex::rng::CortexRng;
use cortex::synthetic::{SyntheticConfig, SyntheticSource};
use cortex::{Cortex, Trainer};

/// A cortex whose flow P is far from the identity (every `p.*` parameter random).
fn bent_cortex() -> Cortex {
    let mut c = Cortex::new(CortexConfig::tiny()).unwrap();
    let mut rng = CortexRng::seed_from(77);
    let ids: Vec<_> = c
        .params
        .ids()
        .filter(|&id| c.params.name(id).starts_with("p."))
        .collect();
    assert_eq!(ids.len(), 48);
    for id in ids {
        for v in c.params.get_mut(id).data_mut() {
            *v = (0.15 * rng.normal()) as f32;
        }
    }
    c
}

fn percept(b: usize, ch: usize, n: usize) -> Tensor<f32> {
    Tensor::from_fn([b, ch, n, n], |i| {
        let (x, y, c) = ((i % n) as f32, ((i / n) % n) as f32, (i / (n * n)) as f32);
        (0.3 * x + 0.1 * c).sin() + (0.23 * y - 0.2 * c).cos()
    })
}

#[test]
fn p_inverse_after_forward_is_identity() {
    let c = bent_cortex();
    let flow = c.p.plain(&c.params);
    let grid = unit_grid(32);
    let mut pts = grid.clone();
    flow.forward(&mut pts);
    let moved = pts
        .iter()
        .zip(&grid)
        .map(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs())
        .fold(0.0, f64::max);
    assert!(
        moved > 0.05,
        "the test flow must be non-trivial, moved {moved}"
    );
    flow.inverse(&mut pts);
    let err = pts
        .iter()
        .zip(&grid)
        .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
        .fold(0.0, f64::max);
    assert!(err < 1e-12, "P⁻¹∘P error {err}");
}

#[test]
fn zero_motion_warps_nothing() {
    let c = bent_cortex();
    let n = 32;
    let mut tape = Tape::<f32>::new();
    let v = tape.constant(percept(2, 3, n));
    let (w, m, _) =
        c.p.warp(&mut tape, &c.params, v, &[], &[[0.0, 0.0], [0.0, 0.0]]);
    assert!(tape.value(w).max_abs_diff(tape.value(v)) < 1e-4);
    assert!(tape.value(m).data().iter().all(|&x| x == 1.0));
}

#[test]
fn identity_p_and_integer_shift_equals_the_shifted_percept() {
    let n = 32;
    let unit = 2.0 / (n as f64 - 1.0);
    let shifts = [[3i64, -2], [-5, 7]];
    let motion: Vec<[f64; 2]> = shifts
        .iter()
        .map(|s| [s[0] as f64 * unit, s[1] as f64 * unit])
        .collect();
    let pv = percept(2, 3, n);
    let expect = |t: &Tensor<f32>, exact: bool| {
        for (b, s) in shifts.iter().enumerate() {
            for c in 0..3 {
                for y in 0..n as i64 {
                    for x in 0..n as i64 {
                        let (ys, xs) = (y + s[1], x + s[0]);
                        if ys < 0 || xs < 0 || ys >= n as i64 || xs >= n as i64 {
                            continue;
                        }
                        let got = t.data()[((b * 3 + c) * n + y as usize) * n + x as usize];
                        let want = pv.data()[((b * 3 + c) * n + ys as usize) * n + xs as usize];
                        if exact {
                            assert_eq!(got, want, "b {b} c {c} y {y} x {x}");
                        } else {
                            assert!(
                                (got - want).abs() < 1e-5,
                                "b {b} c {c} y {y} x {x}: {got} vs {want}"
                            );
                        }
                    }
                }
            }
        }
    };
    // sandbox P: exact gather
    let mut cfg = CortexConfig::tiny();
    cfg.p.mode = PMode::IdentityIntegerShift;
    cfg.p.motion_ons_px_per_unit = 1.0 / unit;
    let sandbox = Cortex::new(cfg).unwrap();
    let mut tape = Tape::<f32>::new();
    let v = tape.constant(pv.clone());
    let (w, _, _) = sandbox.p.warp(&mut tape, &sandbox.params, v, &[], &motion);
    expect(tape.value(w), true);
    // the learned flow at its identity start: bilinear at (f32-rounded) pixel centres
    let flow = Cortex::new(CortexConfig::tiny()).unwrap();
    let (w, _, _) = flow.p.warp(&mut tape, &flow.params, v, &[], &motion);
    expect(tape.value(w), false);
}

#[test]
fn nontrivial_p_warp_matches_independent_resampling() {
    let c = bent_cortex();
    let n = 32;
    let motion = [[0.11, -0.07], [-0.2, 0.05]];
    let pv = percept(2, 2, n);
    let mut tape = Tape::<f32>::new();
    let v = tape.constant(pv.clone());
    let (w, m, _) = c.p.warp(&mut tape, &c.params, v, &[], &motion);
    // independently: the flow's coordinates in f64, then our own bilinear sampler
    let flow = c.p.plain(&c.params);
    let mut max_err = 0.0f64;
    let mut inside = 0;
    for (b, d) in motion.iter().enumerate() {
        let mut pts = unit_grid(n);
        flow.forward(&mut pts);
        for p in pts.iter_mut() {
            *p = [p[0] + d[0], p[1] + d[1]];
        }
        flow.inverse(&mut pts);
        for ch in 0..2 {
            let plane = &pv.data()[(b * 2 + ch) * n * n..(b * 2 + ch + 1) * n * n];
            for (k, &p) in pts.iter().enumerate() {
                let want = bilinear(plane, n, n, p);
                let got = tape.value(w).data()[(b * 2 + ch) * n * n + k] as f64;
                max_err = max_err.max((got - want).abs());
                let mk = tape.value(m).data()[b * n * n + k];
                assert_eq!(
                    mk == 1.0,
                    nearest_inside(n, n, p),
                    "mask at b {b} pixel {k}"
                );
                inside += (mk == 1.0) as usize;
            }
        }
    }
    assert!(inside > n * n, "most pixels should stay inside");
    assert!(max_err < 1e-4, "warp vs independent resampling: {max_err}");
}

#[test]
fn c_stays_unit_norm_through_training() {
    let cfg = CortexConfig::tiny();
    let mut t = Trainer::new(cfg.clone()).unwrap();
    let mut src = SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 8));
    t.run(&mut src, 20, None, |_, _| {}).unwrap();
    let c = t.cortex.learned_c().unwrap();
    let n_ch = cfg.percept_channels;
    let mut moved = 0.0f64;
    for cell in c.data().chunks(n_ch) {
        let norm = cell.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-4, "‖C‖ = {norm}");
        moved = moved.max(cell[1..].iter().map(|v| v.abs()).fold(0.0, f64::max));
    }
    assert!(
        moved > 1e-3,
        "C should have learned something, max off-e1 component {moved}"
    );
}

/// A tiny trainer whose flow P contracts both coordinates as far as its bounded log-scale lets
/// every coupling (`s = −bound` in every block), so that P⁻¹ magnifies the eye's motion.
fn contracting_trainer() -> (Trainer, SyntheticSource) {
    let cfg = CortexConfig::tiny();
    let mut t = Trainer::new(cfg.clone()).unwrap();
    for k in 0..cfg.p.couplings {
        let id = t
            .cortex
            .params
            .find(&format!("p.block{k}.fc3.bias"))
            .expect("a coupling");
        t.cortex.params.get_mut(id).data_mut()[1] = -1e3;
    }
    (
        t,
        SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 5)),
    )
}

#[test]
fn warp_coverage_reports_an_empty_warp() {
    let cfg = CortexConfig::tiny();
    let mut fresh = Trainer::new(cfg.clone()).unwrap();
    let mut src = SyntheticSource::new(SyntheticConfig::lms(cfg.ons_size_px, 5));
    let mut coverage = Vec::new();
    fresh
        .run(&mut src, 2, None, |st, _| coverage.push(st.warp_coverage))
        .unwrap();
    println!("identity P: coverage {coverage:?}");
    assert!(
        coverage.iter().all(|&c| c > 0.0 && c <= 1.0),
        "{coverage:?}"
    );

    let (mut t, mut src) = contracting_trainer();
    let mut seen = Vec::new();
    t.run(&mut src, 2, None, |st, _| {
        seen.push((st.warp_coverage, st.main_loss))
    })
    .unwrap();
    println!("contracting P: (coverage, main loss) {seen:?}");
    let (c, main_loss) = seen[0];
    assert_eq!(c, 0.0, "P⁻¹ magnifies every motion out of the field");
    assert_eq!(
        main_loss, 0.0,
        "an empty warp leaves nothing to compare: {seen:?}"
    );
}

#[test]
fn the_outside_field_guard_is_zero_inside_and_pulls_an_empty_warp_back() {
    use cortex::buckets::p::{outside_field_guard, PBucket, Sampling};
    let c = bent_cortex();
    let n = 32;
    for (motion, empty) in [([0.0, 0.0], false), ([6.0, -6.0], true)] {
        let mut tape = Tape::<f32>::new();
        let v = tape.constant(percept(2, 3, n));
        let sampling = c.p.sampling(&mut tape, &c.params, &[motion, motion]);
        let Sampling::Grid(grid) = sampling else {
            panic!("a flow samples through a grid")
        };
        let (_, mask) = PBucket::resample(&mut tape, &sampling, v);
        let mask_sum: f32 = tape.value(mask).data().iter().sum();
        assert_eq!(mask_sum == 0.0, empty, "mask sum {mask_sum}");
        // The guard by hand: Σ over points and axes of relu(|u′| − 1)², over the batch of 2.
        let want: f64 = tape
            .value(grid)
            .data()
            .iter()
            .map(|&u| (u.abs() as f64 - 1.0).max(0.0).powi(2))
            .sum::<f64>()
            / 2.0;
        let guard = outside_field_guard(&mut tape, grid);
        let got = tape.value(guard).data()[0] as f64;
        assert!(
            (got - want).abs() <= 1e-5 * want.max(1.0),
            "{got} vs {want}"
        );
        tape.backward(guard);
        let p_grad: f64 = tape
            .param_grads()
            .filter(|(id, _)| c.params.name(*id).starts_with("p."))
            .map(|(_, g)| g.data().iter().map(|&x| (x as f64).abs()).sum::<f64>())
            .sum();
        if empty {
            assert!(got > 1.0, "an empty warp is guarded: {got}");
            assert!(p_grad > 0.0, "and the guard reaches P");
        } else {
            // No point of a still warp lies outside; the field's edge points come back from
            // P⁻¹∘P within f32 round-off of ±1.
            assert!(got < 1e-10, "{got}");
            assert!(p_grad < 1e-4, "{p_grad}");
        }
    }
}

#[test]
fn the_guard_enters_the_loss_by_its_weight_and_records_nothing_at_zero() {
    use cortex::buckets::p::{outside_field_guard, Sampling};
    use cortex::config::MMode;
    use cortex::model::MotionOut;
    let n = 32;
    let motion = MotionOut {
        motion: vec![[0.4, -0.3], [0.0, 0.0]],
        blurred: None,
    };
    let record = |weight: f64| {
        let mut cfg = CortexConfig::tiny();
        cfg.m.mode = MMode::Oracle;
        cfg.loss.outside_field_weight = weight;
        let c = Cortex::new(cfg).unwrap();
        let mut tape = Tape::<f32>::new();
        let o1 = tape.constant(percept(2, 1, n));
        let o2 = tape.constant(percept(2, 1, n));
        let p = c.record_prediction(&mut tape, o1, o2, &motion);
        let (loss, main) = (tape.value(p.loss).item(), tape.value(p.main_loss).item());
        // The guard of the same sampling, recorded apart.
        let Sampling::Grid(grid) = c.p.sampling(&mut tape, &c.params, &motion.motion) else {
            panic!("a flow samples through a grid")
        };
        let g = outside_field_guard(&mut tape, grid);
        (
            loss as f64,
            main as f64,
            tape.value(g).item() as f64,
            tape.len(),
        )
    };
    let (loss0, main0, guard, len0) = record(0.0);
    assert_eq!(loss0, main0, "no guard at weight 0");
    assert!(
        guard > 0.0,
        "the test's motion moves points outside: {guard}"
    );
    let (loss, main, _, len) = record(0.5);
    assert_eq!(main, main0);
    assert!(
        ((loss - main) - 0.5 * guard).abs() <= 1e-5 * guard,
        "{loss} {main} {guard}"
    );
    assert!(
        len > len0,
        "the guard's ops are recorded only when weighted"
    );
}
