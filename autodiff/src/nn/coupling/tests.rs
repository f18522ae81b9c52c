//! Tests of the fused affine coupling: gradients, inverse, feedback alignment and agreement of the kernel builds.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use crate::learn::{Backprop, FeedbackAlignment, LearningRule, ParamGrads};
use crate::{ParamId, ParamStore};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Points `(n, 2)` in [−2, 2], then `w1, b1, w2, b2, w3, b3` for hidden width `h`, all
/// non-zero (last layer ±0.5/√h, so the scale `exp(s)` is not trivially 1). Conditioning
/// values (column `kept`) are redrawn until every ReLU input is at least 1e-3 from its
/// kink, far beyond the finite-difference steps of the checks. Some MLPs have no such value
/// (about 1 in 3 000 at `h = 1`: a unit whose input stays within 1e-3 of zero for every
/// `x_c` in [−2, 2]); after [`REDRAWS`] tries for one point the whole set is drawn again,
/// so every seed gives inputs in bounded time.
fn inputs(seed: u64, n: usize, h: usize, kept: usize) -> Vec<Tensor<f64>> {
    let mut rng = StdRng::seed_from_u64(seed);
    loop {
        let mut x = draw_mlp(&mut rng, h);
        x.insert(
            0,
            Tensor::from_fn(&[n, 2][..], |_| rng.random_range(-2.0..2.0)),
        );
        if (0..n).all(|i| place_away_from_kinks(&mut x, 2 * i + kept, &mut rng)) {
            return x;
        }
    }
}

/// `w1, b1, w2, b2, w3, b3` of hidden width `h`, uniform in the bounds [`inputs`] states.
fn draw_mlp(rng: &mut StdRng, h: usize) -> Vec<Tensor<f64>> {
    let r = 1.0 / (h as f64).sqrt();
    let mut u =
        |shape: &[usize], bound: f64| Tensor::from_fn(shape, |_| rng.random_range(-bound..bound));
    vec![
        u(&[1, h], 1.0),
        u(&[h], 1.0),
        u(&[h, h], r),
        u(&[h], 0.5),
        u(&[h, 2], 0.5 * r),
        u(&[2], 0.5),
    ]
}

/// A seed whose first MLP at `h = 1` has no kink-free conditioning value.
const HOPELESS_SEED: u64 = 2708;

/// Tries for one conditioning value before [`inputs`] gives up on an MLP.
const REDRAWS: usize = 1000;

/// Redraws `x[0][at]` in [−2, 2] until no ReLU input is within 1e-3 of its kink; `false`
/// when [`REDRAWS`] draws all fail.
fn place_away_from_kinks(x: &mut [Tensor<f64>], at: usize, rng: &mut StdRng) -> bool {
    for _ in 0..REDRAWS {
        let (a1, a2) = preacts(x, x[0].data()[at]);
        if a1.iter().chain(&a2).all(|a| a.abs() >= 1e-3) {
            return true;
        }
        x[0].data_mut()[at] = rng.random_range(-2.0..2.0);
    }
    false
}

/// Every seed gives inputs, including one whose first MLP has no kink-free conditioning
/// value (its only unit's input stays within 1e-3 of zero over [−2, 2]; before the whole
/// set was redrawn, the search for a point never ended).
#[test]
fn inputs_exist_for_every_seed_even_without_a_kink_free_value() {
    let (seed, h) = (HOPELESS_SEED, 1);
    let mut mlp = draw_mlp(&mut StdRng::seed_from_u64(seed), h);
    mlp.insert(0, Tensor::zeros(&[1usize, 2][..]));
    let kink_free = |v: f64| {
        let (a1, a2) = preacts(&mlp, v);
        a1.iter().chain(&a2).all(|a| a.abs() >= 1e-3)
    };
    assert!(
        !(0..=4000).any(|i| kink_free(-2.0 + i as f64 * 1e-3)),
        "seed {seed} was chosen for a first MLP without a kink-free value"
    );
    let x = inputs(seed, 3, h, 0);
    for i in 0..3 {
        let (a1, a2) = preacts(&x, x[0].data()[2 * i]);
        assert!(a1.iter().chain(&a2).all(|a| a.abs() >= 1e-3), "point {i}");
    }
}

/// The ReLU inputs `(x_c·w1 + b1, h1·w2 + b2)` of the MLP in `p[1..7]` at `v = x_c`.
fn preacts(p: &[Tensor<f64>], v: f64) -> (Vec<f64>, Vec<f64>) {
    let h = p[2].numel();
    let [w1, b1, w2, b2] = std::array::from_fn(|i| p[i + 1].data());
    let a1: Vec<f64> = (0..h).map(|j| v * w1[j] + b1[j]).collect();
    let a2 = (0..h)
        .map(|k| b2[k] + (0..h).map(|j| a1[j].max(0.0) * w2[j * h + k]).sum::<f64>())
        .collect();
    (a1, a2)
}

fn check(
    x: &[Tensor<f64>],
    kept: usize,
    inverse: bool,
    bound: Option<f64>,
) -> Result<(), TestCaseError> {
    let f = |t: &mut Tape<f64>, v: &[Var]| t.affine_coupling(v[0], &v[1..], kept, inverse, bound);
    check_gradients(f, x, &CheckConfig::default())
        .map(|_| ())
        .map_err(|e| {
            TestCaseError::fail(format!(
                "kept {kept}, inverse {inverse}, bound {bound:?}: {e}"
            ))
        })
}

proptest! {
    #![proptest_config(st::config())]

    /// affine_coupling: gradients to the points and all six parameters, point counts
    /// across the chunk boundary (64), both columns, both directions, unbounded and bounded
    /// log-scales (bounds from 0.2, where `tanh` bends within the drawn log-scales, to 3).
    #[test]
    fn affine_coupling_gradients(
        n in 1usize..=70, h in 1usize..=5, kept in 0usize..2, inverse in any::<bool>(),
        seed in any::<u64>(), bound in proptest::option::of(0.2f64..3.0),
    ) {
        check(&inputs(seed, n, h, kept), kept, inverse, bound)?;
    }
}

/// The official width (16) and more points than one parallel block, so the per-block
/// partial sums of the parameter gradients are exercised.
#[test]
fn affine_coupling_gradients_across_blocks() {
    for (kept, inverse) in [(0, false), (1, true)] {
        check(
            &inputs(11, BLOCK + CHUNK + 5, 16, kept),
            kept,
            inverse,
            None,
        )
        .unwrap();
        check(
            &inputs(12, BLOCK + CHUNK + 5, 16, kept),
            kept,
            inverse,
            Some(0.5),
        )
        .unwrap();
    }
}

#[test]
fn inverse_undoes_forward() {
    let x = inputs(5, 300, 16, 0);
    let mut tape = Tape::<f64>::new();
    let v: Vec<Var> = x.iter().map(|t| tape.constant(t.clone())).collect();
    for (kept, bound) in [(0, None), (1, None), (0, Some(0.3)), (1, Some(0.3))] {
        let y = tape.affine_coupling(v[0], &v[1..], kept, false, bound);
        assert!(
            tape.value(y).max_abs_diff(&x[0]) > 1e-2,
            "the coupling moves points"
        );
        let back = tape.affine_coupling(y, &v[1..], kept, true, bound);
        assert!(tape.value(back).max_abs_diff(&x[0]) < 1e-12);
    }
}

/// The points and MLP of [`inputs`] with the log-scale's bias pushed to `s_bias`: far enough
/// (±95) and `exp(∓s)` overflows f32.
fn pushed(s_bias: f64, kept: usize) -> Vec<Tensor<f64>> {
    let mut x = inputs(7, 200, 16, kept);
    x[6].data_mut()[1] = s_bias;
    x
}

/// Gradients of `Σ r ⊙ coupling(x)` in f32 to the points and the six parameters, with the
/// error `r` zero on the first half of the points (as a warp's mask zeroes the pixels whose
/// sampling point left the image).
fn f32_grads(
    x: &[Tensor<f64>],
    kept: usize,
    inverse: bool,
    bound: Option<f64>,
) -> Vec<Tensor<f32>> {
    let n = x[0].shape().dim(0);
    let r = Tensor::from_fn([n, 2], |i| if i < n { 0.0 } else { 1.0 });
    let mut tape = Tape::<f32>::new();
    let v: Vec<Var> = x.iter().map(|t| tape.leaf(t.cast())).collect();
    let y = tape.affine_coupling(v[0], &v[1..], kept, inverse, bound);
    tape.backward_from(&[(y, r.cast())], &mut crate::NoHooks);
    v.iter().map(|&v| tape.grad(v).unwrap().clone()).collect()
}

/// The hole P's inverse had: a log-scale pushed to ±95 overflows `exp(∓s)` in f32. Bounded,
/// the map scales by at most `e^a` and every gradient is finite; unbounded (the authors'
/// form), the points whose error is zero still contribute exactly zero (no `0·∞ = NaN`).
#[test]
fn a_pushed_log_scale_gives_finite_gradients() {
    for (s_bias, inverse) in [(-95.0, true), (95.0, false)] {
        let x = pushed(s_bias, 0);
        let bounded = f32_grads(&x, 0, inverse, Some(2.0));
        for (i, g) in bounded.iter().enumerate() {
            assert!(
                g.data().iter().all(|v| v.is_finite()),
                "bounded, s bias {s_bias}, gradient {i} is not finite"
            );
        }
        let mut tape = Tape::<f32>::new();
        let v: Vec<Var> = x.iter().map(|t| tape.constant(t.cast())).collect();
        let y = tape.affine_coupling(v[0], &v[1..], 0, inverse, Some(2.0));
        let moved = tape
            .value(y)
            .data()
            .iter()
            .map(|v| v.abs())
            .fold(0.0f32, f32::max);
        assert!(
            moved < 3.0 * 2f32.exp() + 10.0,
            "bounded map moved a point to {moved}"
        );
    }
    // Unbounded, the inverse overflows where s ≈ −95; the masked half must not turn NaN.
    let x = pushed(-95.0, 0);
    let g = f32_grads(&x, 0, true, None);
    assert!(
        g[0].data()[..x[0].shape().dim(0)]
            .iter()
            .all(|v| !v.is_nan()),
        "points whose error is zero got NaN gradients"
    );
}

/// `∂L/∂x` of `L = Σ r ⊙ coupling(x)` point by point in plain f64, with the MLP's forward
/// weights `p` for the activations and `b = (B1, B2, B3)` for the error sent to `x_c`.
fn point_grad_reference(
    p: &[Tensor<f64>],
    b: &[Tensor<f64>],
    r: &Tensor<f64>,
    kept: usize,
    inverse: bool,
) -> Tensor<f64> {
    let (x, h, o) = (p[0].data(), p[2].numel(), 1 - kept);
    let (w3, b3) = (p[5].data(), p[6].data());
    let mut out = Tensor::zeros(p[0].shape());
    for (i, g) in out.data_mut().chunks_mut(2).enumerate() {
        let (v, xo) = (x[2 * i + kept], x[2 * i + o]);
        let (a1, a2) = preacts(p, v);
        let ts = |c: usize| b3[c] + (0..h).map(|k| a2[k].max(0.0) * w3[2 * k + c]).sum::<f64>();
        let (t, s) = (ts(0), ts(1));
        let go = r.data()[2 * i + o];
        let (gt, gs, gxo) = if inverse {
            let e = (-s).exp();
            (-go * e, -go * (xo - t) * e, go * e)
        } else {
            (go, go * xo * s.exp(), go * s.exp())
        };
        let [b1m, b2m, b3m] = [b[0].data(), b[1].data(), b[2].data()];
        let gh2: Vec<f64> = (0..h)
            .map(|k| {
                if a2[k] > 0.0 {
                    b3m[2 * k] * gt + b3m[2 * k + 1] * gs
                } else {
                    0.0
                }
            })
            .collect();
        let dv: f64 = (0..h)
            .filter(|&j| a1[j] > 0.0)
            .map(|j| b1m[j] * (0..h).map(|k| b2m[j * h + k] * gh2[k]).sum::<f64>())
            .sum();
        g[kept] = r.data()[2 * i + kept] + dv;
        g[o] = gxo;
    }
    out
}

/// Under feedback alignment the coupling's parameters get their exact gradient and the
/// points' error goes through the feedback matrices; with `B = W` it is backprop.
#[test]
fn feedback_alignment_sends_the_point_error_through_b() {
    let (h, n) = (5, 70);
    let x = inputs(21, n, h, 0);
    let mut rng = StdRng::seed_from_u64(22);
    let r = Tensor::from_fn([n, 2], |_| rng.random_range(-1.0..1.0));
    let b: Vec<Tensor<f64>> = [1, 3, 5]
        .iter()
        .map(|&i| Tensor::from_fn(x[i].shape(), |_| rng.random_range(-1.0..1.0)))
        .collect();
    let mut store = ParamStore::<f64>::new();
    let ids: Vec<ParamId> = (1..7)
        .map(|i| store.add(format!("p{i}"), x[i].clone()))
        .collect();
    for (kept, inverse) in [(0, false), (1, true)] {
        let run = |rule: &mut dyn LearningRule<f64>| -> (ParamGrads<f64>, Tensor<f64>) {
            let mut tape = Tape::new();
            let xv = tape.leaf(x[0].clone());
            let vars: Vec<Var> = ids.iter().map(|&id| store.var(&mut tape, id)).collect();
            let y = tape.affine_coupling(xv, &vars, kept, inverse, None);
            let rv = tape.constant(r.clone());
            let l = tape.mul(y, rv);
            let l = tape.sum(l);
            let g = rule.assign_credit(&mut tape, l.into(), &store);
            (g, tape.grad(xv).unwrap().clone())
        };
        let (bp, bp_x) = run(&mut Backprop);
        let w: Vec<Tensor<f64>> = [1, 3, 5].iter().map(|&i| x[i].clone()).collect();
        let bp_ref = point_grad_reference(&x, &w, &r, kept, inverse);
        assert!(
            bp_x.max_abs_diff(&bp_ref) < 1e-12,
            "backprop point gradient"
        );

        let mut fa = FeedbackAlignment::new(1);
        for (k, &i) in [0, 2, 4].iter().enumerate() {
            fa.set_feedback(ids[i], b[k].clone());
        }
        let (g, gx) = run(&mut fa);
        for &id in &ids {
            assert!(g.get(id).unwrap().max_abs_diff(bp.get(id).unwrap()) < 1e-12);
        }
        let want = point_grad_reference(&x, &b, &r, kept, inverse);
        assert!(gx.max_abs_diff(&want) < 1e-12, "feedback point gradient");
        assert!(
            gx.max_abs_diff(&bp_x) > 1e-2,
            "feedback must change the point error"
        );

        let mut same = FeedbackAlignment::new(1);
        for &i in &[0, 2, 4] {
            same.set_feedback(ids[i], x[i + 1].clone());
        }
        assert!(run(&mut same).1.max_abs_diff(&bp_x) < 1e-12);
    }
}

/// Output and gradients (points, then the six parameters) of `Σ r ⊙ coupling(x)` with
/// kernel build `isa`, in the scalar type `T`.
fn run_build<T: Float>(
    x: &[Tensor<f64>],
    r: &Tensor<f64>,
    kept: usize,
    inverse: bool,
    isa: Isa,
) -> Vec<Tensor<f64>> {
    let mut tape = Tape::<T>::new();
    let v: Vec<Var> = x.iter().map(|t| tape.leaf(t.cast())).collect();
    let y = tape.apply(
        AffineCoupling::with_isa(kept, inverse, isa).with_log_scale_bound(Some(1.5)),
        &v,
    );
    tape.backward_from(&[(y, r.cast())], &mut crate::NoHooks);
    let mut out = vec![tape.value(y).cast()];
    out.extend(v.iter().map(|&v| tape.grad(v).unwrap().cast()));
    out
}

/// Every kernel build this CPU runs (AVX-512, AVX2 + FMA, portable), in f32 and f64,
/// against the portable f64 build: f64 to 1e-12, f32 to 1e-4 of each tensor's largest
/// entry. Covers the f32-only paths (vector `exp`, the intrinsic outer products).
#[test]
fn kernel_builds_agree() {
    let n = BLOCK + CHUNK + 6;
    let mut rng = StdRng::seed_from_u64(31);
    let r = Tensor::from_fn([n, 2], |_| rng.random_range(-1.0..1.0));
    for (kept, inverse) in [(0, false), (1, true)] {
        let x = inputs(32, n, 16, kept);
        let reference = run_build::<f64>(&x, &r, kept, inverse, Isa::Portable);
        for isa in Isa::available() {
            let builds = [
                ("f64", run_build::<f64>(&x, &r, kept, inverse, isa), 1e-12),
                ("f32", run_build::<f32>(&x, &r, kept, inverse, isa), 1e-4),
            ];
            for (ty, got, tol) in builds {
                for (i, (a, b)) in got.iter().zip(&reference).enumerate() {
                    let scale = b.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    assert!(
                        a.max_abs_diff(b) <= tol * scale,
                        "{isa:?} {ty}, inverse {inverse}, output {i}: {} vs scale {scale}",
                        a.max_abs_diff(b)
                    );
                }
            }
        }
    }
}

/// The vectorisable f32 `exp` of the SIMD builds against f64 `exp`: within 2 units in the
/// last place (2·2⁻²³ relative) for normal results, within one denormal step below, and
/// the IEEE special cases.
#[test]
fn exp_f32_matches_f64_exp() {
    let steps = 400_000;
    for i in 0..=steps {
        let x = -104.0 + (88.72f64 + 104.0) * i as f64 / steps as f64;
        let x = x as f32;
        let (got, want) = (tiles::exp_f32(x) as f64, (x as f64).exp());
        if want >= f32::MIN_POSITIVE as f64 {
            let rel = (got - want).abs() / want;
            assert!(
                rel <= 2.0 * f32::EPSILON as f64,
                "exp({x}) = {got}, want {want}"
            );
        } else {
            assert!(
                (got - want).abs() <= 2f64.powi(-149),
                "exp({x}) = {got}, want {want}"
            );
        }
    }
    assert_eq!(tiles::exp_f32(0.0), 1.0);
    assert_eq!(tiles::exp_f32(88.8), f32::INFINITY);
    assert_eq!(tiles::exp_f32(f32::INFINITY), f32::INFINITY);
    assert_eq!(tiles::exp_f32(-120.0), 0.0);
    assert_eq!(tiles::exp_f32(f32::NEG_INFINITY), 0.0);
    assert!(tiles::exp_f32(f32::NAN).is_nan());
}

#[test]
#[should_panic(expected = "affine_coupling: w2 (3, 4) does not match w1 (1, 4) (want (4, 4))")]
fn mismatched_hidden_width_panics() {
    let mut x = inputs(0, 3, 4, 0);
    x[3] = Tensor::zeros([3, 4]);
    let mut tape = Tape::<f64>::new();
    let v: Vec<Var> = x.into_iter().map(|t| tape.constant(t)).collect();
    tape.affine_coupling(v[0], &v[1..], 0, false, None);
}
