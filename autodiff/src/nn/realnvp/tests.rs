//! Tests of the RealNVP flow: size, identity at initialisation, inverse, log-determinant and gradients.

use super::*;
use crate::check::{check_gradients, strategies, CheckConfig};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// A flow away from the identity: PyTorch-default hidden layers and last layers drawn
/// with std 0.1, so each block shifts and scales by roughly ±20 % (a learned-looking map;
/// much larger weights compound over 8 blocks into `exp(50)` scales).
fn random_flow(seed: u64, cfg: RealNvpConfig) -> (ParamStore<f64>, RealNvp) {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut store = ParamStore::new();
    let flow = RealNvp::new(&mut store, "p", cfg, &mut rng);
    let normal = Normal::new(0.0, 0.1).unwrap();
    for ids in flow.param_ids().chunks(PER_BLOCK) {
        for &id in &ids[4..] {
            store
                .get_mut(id)
                .data_mut()
                .iter_mut()
                .for_each(|v| *v = normal.sample(&mut rng));
        }
    }
    (store, flow)
}

/// Block `k` (or its inverse) recorded op by op (slice, linear, relu, exp, mul, add,
/// concat): the implementation before the fused op, kept as the reference.
fn coupling_op_by_op(tape: &mut Tape<f64>, w: &[Var], p: Var, k: usize, inverse: bool) -> Var {
    let c = k % 2;
    let kept = tape.slice(p, c, 1);
    let moved = tape.slice(p, 1 - c, 1);
    let h1 = tape.linear(kept, w[0], w[1]);
    let h1 = tape.relu(h1);
    let h2 = tape.linear(h1, w[2], w[3]);
    let h2 = tape.relu(h2);
    let ts = tape.linear(h2, w[4], w[5]);
    let (t, s) = (tape.slice(ts, 0, 1), tape.slice(ts, 1, 1));
    let moved = if inverse {
        let shifted = tape.sub(moved, t);
        let neg = tape.neg(s);
        let inv_scale = tape.exp(neg);
        tape.mul(shifted, inv_scale)
    } else {
        let scale = tape.exp(s);
        let scaled = tape.mul(moved, scale);
        tape.add(scaled, t)
    };
    if c == 0 {
        tape.concat(&[kept, moved])
    } else {
        tape.concat(&[moved, kept])
    }
}

/// The flow's value at `x` and the gradients of `Σ r ⊙ flow(x)` to the points and to
/// every parameter, through the fused ops or op by op.
fn value_and_grads(
    flow: &RealNvp,
    store: &ParamStore<f64>,
    x: &Tensor<f64>,
    r: &Tensor<f64>,
    inverse: bool,
    fused: bool,
) -> Vec<Tensor<f64>> {
    let mut tape = Tape::<f64>::new();
    let vars = flow.record(&mut tape, store);
    let xv = tape.leaf(x.clone());
    let y = match (fused, inverse) {
        (true, false) => flow.forward_with(&mut tape, &vars, xv),
        (true, true) => flow.inverse_with(&mut tape, &vars, xv),
        (false, _) => {
            let nb = flow.config().blocks;
            (0..nb).fold(xv, |p, j| {
                let k = if inverse { nb - 1 - j } else { j };
                let w = &vars.0[k * PER_BLOCK..][..PER_BLOCK];
                coupling_op_by_op(&mut tape, w, p, k, inverse)
            })
        }
    };
    tape.backward_from(&[(y, r.clone())], &mut crate::NoHooks);
    let mut out = vec![tape.value(y).clone(), tape.grad(xv).unwrap().clone()];
    out.extend(vars.0.iter().map(|&v| tape.grad(v).unwrap().clone()));
    out
}

/// The smallest |ReLU input| met while mapping `p` forward through `flow`.
fn kink_distance(flow: &RealNvp, store: &ParamStore<f64>, mut p: [f64; 2]) -> f64 {
    let h = flow.config().hidden;
    let mut nearest = f64::INFINITY;
    for (k, ids) in flow.param_ids().chunks(PER_BLOCK).enumerate() {
        let [w1, b1, w2, b2, w3, b3] = std::array::from_fn(|i| store.get(ids[i]).data());
        let c = k % 2;
        let a1: Vec<f64> = (0..h).map(|j| p[c] * w1[j] + b1[j]).collect();
        let a2: Vec<f64> = (0..h)
            .map(|m| b2[m] + (0..h).map(|j| a1[j].max(0.0) * w2[j * h + m]).sum::<f64>())
            .collect();
        nearest = a1.iter().chain(&a2).fold(nearest, |n, a| n.min(a.abs()));
        let out = |o: usize| b3[o] + (0..h).map(|m| a2[m].max(0.0) * w3[2 * m + o]).sum::<f64>();
        p[1 - c] = p[1 - c] * out(1).exp() + out(0);
    }
    nearest
}

fn points(seed: u64, n: usize) -> Tensor<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    Tensor::from_fn([n, 2], |_| rng.random_range(-1.0..1.0))
}

#[test]
fn official_size_has_2704_parameters() {
    let mut store = ParamStore::<f32>::new();
    let flow = RealNvp::new(
        &mut store,
        "cortex.p",
        RealNvpConfig::default(),
        &mut StdRng::seed_from_u64(1),
    );
    assert_eq!(store.numel(), 2704);
    assert_eq!(flow.num_params(), 2704);
    assert_eq!(store.len(), 48);
    assert!(store.find("cortex.p.block7.fc3.bias").is_some());
}

#[test]
fn identity_at_initialisation() {
    let mut store = ParamStore::<f64>::new();
    let flow = RealNvp::new(
        &mut store,
        "p",
        RealNvpConfig::default(),
        &mut StdRng::seed_from_u64(2),
    );
    let x = points(3, 50);
    assert_eq!(flow.forward_points(&store, &x), x);
    assert_eq!(flow.inverse_points(&store, &x), x);
    assert!(flow
        .log_det_jacobian(&store, &x)
        .data()
        .iter()
        .all(|&v| v == 0.0));
    let mut tape = Tape::<f64>::new();
    let v = tape.constant(x.clone());
    let y = flow.forward(&mut tape, &store, v);
    assert_eq!(tape.value(y), &x);
}

proptest! {
    #![proptest_config(strategies::config())]

    #[test]
    fn inverse_undoes_forward_for_random_parameters(seed in any::<u64>()) {
        let (store, flow) = random_flow(seed, RealNvpConfig::default());
        let x = points(seed ^ 1, 64);
        let y = flow.forward_points(&store, &x);
        prop_assert!(y.max_abs_diff(&x) > 1e-2, "random parameters must move the points");
        prop_assert!(flow.inverse_points(&store, &y).max_abs_diff(&x) < 1e-5);
        // The same on the tape, recording the parameters once for both directions.
        let mut tape = Tape::<f64>::new();
        let vars = flow.record(&mut tape, &store);
        let v = tape.constant(x.clone());
        let fy = flow.forward_with(&mut tape, &vars, v);
        prop_assert!(tape.value(fy).max_abs_diff(&y) < 1e-12, "tape and plain forward differ");
        let back = flow.inverse_with(&mut tape, &vars, fy);
        prop_assert!(tape.value(back).max_abs_diff(&x) < 1e-5);
    }

    /// The fused tape path equals the op-by-op one (values, and the gradients to points and
    /// all 48 parameters) to 1e-10 relative, both directions, on a random flow and more
    /// points than one chunk of the fused op.
    #[test]
    fn fused_couplings_match_op_by_op(seed in any::<u64>()) {
        let (store, flow) = random_flow(seed, RealNvpConfig::default());
        let x = points(seed ^ 4, 100);
        let r = points(seed ^ 5, 100);
        for inverse in [false, true] {
            let fused = value_and_grads(&flow, &store, &x, &r, inverse, true);
            let reference = value_and_grads(&flow, &store, &x, &r, inverse, false);
            for (i, (a, b)) in fused.iter().zip(&reference).enumerate() {
                let scale = b.data().iter().fold(1.0f64, |m, v| m.max(v.abs()));
                prop_assert!(
                    a.max_abs_diff(b) <= 1e-10 * scale,
                    "inverse = {inverse}, output {i} (0 value, 1 points, 2.. parameters): {} vs scale {scale}",
                    a.max_abs_diff(b)
                );
            }
        }
    }

    /// `log |det J|` against a central-difference Jacobian of `forward_points`.
    #[test]
    fn log_det_matches_finite_difference_jacobian(seed in any::<u64>()) {
        let (store, flow) = random_flow(seed, RealNvpConfig::default());
        // Central differences across a ReLU kink are wrong: keep points whose every ReLU
        // input along the flow is at least 1e-4 from 0 (100× the step).
        let kept: Vec<f64> = points(seed ^ 2, 64)
            .data()
            .chunks(2)
            .filter(|p| kink_distance(&flow, &store, [p[0], p[1]]) >= 1e-4)
            .take(8)
            .flatten()
            .copied()
            .collect();
        prop_assert_eq!(kept.len(), 16, "fewer than 8 of 64 points clear of kinks");
        let x = Tensor::from_vec([8, 2], kept);
        let ld = flow.log_det_jacobian(&store, &x);
        let h = 1e-6;
        for i in 0..8 {
            let mut jac = [[0.0; 2]; 2];
            for (a, col) in [0usize, 1].iter().zip(0..2) {
                let shifted = |d: f64| {
                    let mut p = Tensor::from_vec([1, 2], x.data()[2 * i..2 * i + 2].to_vec());
                    p.data_mut()[*a] += d;
                    flow.forward_points(&store, &p)
                };
                let (plus, minus) = (shifted(h), shifted(-h));
                for (r, row) in jac.iter_mut().enumerate() {
                    row[col] = (plus.data()[r] - minus.data()[r]) / (2.0 * h);
                }
            }
            let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
            prop_assert!((det.abs().ln() - ld.data()[i]).abs() < 1e-6, "point {i}: fd {} vs {}", det.abs().ln(), ld.data()[i]);
        }
    }

    /// Gradients to the points and to every parameter, through both directions, on a
    /// small flow (2 blocks, hidden 3) with random parameters. Central differences across a
    /// ReLU kink are wrong, so the points are kept clear of kinks on both paths: every ReLU
    /// input met mapping a point forward, and mapping its inverse forward (the inverse pass
    /// meets the same inputs), at least 1e-4 from 0 (100× the step).
    #[test]
    fn forward_and_inverse_gradients(seed in any::<u64>()) {
        let cfg = RealNvpConfig {
            blocks: 2,
            hidden: 3,
            log_scale_bound: None,
        };
        let (store, flow) = random_flow(seed, cfg);
        let candidates = points(seed ^ 3, 64);
        let inverses = flow.inverse_points(&store, &candidates);
        let kept: Vec<f64> = (0..64)
            .filter(|&i| {
                let at = |t: &Tensor<f64>| [t.data()[2 * i], t.data()[2 * i + 1]];
                kink_distance(&flow, &store, at(&candidates)) >= 1e-4
                    && kink_distance(&flow, &store, at(&inverses)) >= 1e-4
            })
            .take(4)
            .flat_map(|i| candidates.data()[2 * i..2 * i + 2].to_vec())
            .collect();
        prop_assert_eq!(kept.len(), 8, "fewer than 4 of 64 points clear of kinks");
        let mut inputs = vec![Tensor::from_vec([4, 2], kept)];
        inputs.extend(flow.param_ids().iter().map(|&id| store.get(id).clone()));
        for inverse in [false, true] {
            let f = |t: &mut Tape<f64>, v: &[Var]| {
                let vars = RealNvpVars::new(v[1..].to_vec());
                if inverse { flow.inverse_with(t, &vars, v[0]) } else { flow.forward_with(t, &vars, v[0]) }
            };
            check_gradients(f, &inputs, &CheckConfig::default())
                .map_err(|e| TestCaseError::fail(format!("inverse = {inverse}: {e}")))?;
        }
    }
}

#[test]
#[should_panic(expected = "realnvp: expected points (N, 2), got (4, 3)")]
fn wrong_point_shape_panics() {
    let mut store = ParamStore::<f32>::new();
    let flow = RealNvp::new(
        &mut store,
        "p",
        RealNvpConfig::default(),
        &mut StdRng::seed_from_u64(0),
    );
    let mut tape = Tape::<f32>::new();
    let x = tape.constant(Tensor::zeros([4, 3]));
    flow.forward(&mut tape, &store, x);
}
