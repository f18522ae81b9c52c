//! The extension API, exercised only through the public interface, the way a researcher would:
//! a custom op with its own backward and saved state, a surrogate-gradient spike, hooks that
//! replace a VJP or read an intermediate gradient, retained gradients, frozen parameters under
//! Adam, feedback alignment against backprop, and safetensors checkpoints.

use autodiff::check::{check_gradients, check_surrogate, CheckConfig};
use autodiff::learn::{Backprop, FeedbackAlignment, LearningRule};
use autodiff::optim::{Adam, Optimizer};
use autodiff::{
    BackwardCx, BackwardHooks, GradSlots, NodeView, Op, ParamId, ParamStore, Pointwise,
};
use autodiff::{Shape, Tape, Tensor, Var};
use std::collections::BTreeMap;

/// Sorts a vector ascending. Saved state: the permutation found in forward, which backward
/// uses to route each output gradient back to the element it came from.
#[derive(Default)]
struct Sort {
    perm: Vec<usize>,
}

impl Op<f64> for Sort {
    fn name(&self) -> &'static str {
        "sort"
    }
    fn output_shape(&self, inputs: &[&Tensor<f64>]) -> Shape {
        assert_eq!(
            inputs[0].shape().rank(),
            1,
            "sort: wants a vector, got {:?}",
            inputs[0].shape()
        );
        inputs[0].shape()
    }
    fn forward(&mut self, inputs: &[&Tensor<f64>], out: &mut Tensor<f64>) {
        let x = inputs[0].data();
        self.perm = (0..x.len()).collect();
        self.perm.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
        for (o, &p) in out.data_mut().iter_mut().zip(&self.perm) {
            *o = x[p];
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, f64>, dx: &mut GradSlots<'_, f64>) {
        if let Some(g) = dx.slot_data(0) {
            for (i, &p) in self.perm.iter().enumerate() {
                g[p] += cx.dy.data()[i];
            }
        }
    }
}

#[test]
fn custom_op_with_saved_state_passes_the_gradient_check() {
    let x = Tensor::from_vec([5], vec![0.3, -1.2, 2.0, 0.9, -0.4]);
    // Compose with built-ins so the check sees a non-trivial chain.
    let report = check_gradients(
        |t, v| {
            let s = t.apply(Sort::default(), &[v[0]]);
            t.square(s)
        },
        std::slice::from_ref(&x),
        &CheckConfig::default(),
    )
    .unwrap();
    assert_eq!(report.checked, 5);
    let mut t = Tape::<f64>::new();
    let xv = t.constant(x);
    let s = t.apply(Sort::default(), &[xv]);
    assert_eq!(t.value(s).data(), &[-1.2, -0.4, 0.3, 0.9, 2.0]);
}

/// Heaviside spike with the SuperSpike surrogate `1 / (1 + β|v − θ|)²` (Zenke & Ganguli 2018).
struct SuperSpike {
    theta: f64,
    beta: f64,
}

impl Pointwise for SuperSpike {
    fn name(&self) -> &'static str {
        "spike_superspike"
    }
    fn f(&self, v: f64) -> f64 {
        if v >= self.theta {
            1.0
        } else {
            0.0
        }
    }
    fn df(&self, v: f64, _y: f64) -> f64 {
        (1.0 + self.beta * (v - self.theta).abs()).powi(-2)
    }
    fn exact(&self) -> bool {
        false
    }
}

#[test]
fn surrogate_spike_uses_its_declared_derivative() {
    let v = Tensor::from_vec([4], vec![0.2, 0.95, 1.05, 1.8]);
    let spike = || SuperSpike {
        theta: 1.0,
        beta: 10.0,
    };
    check_surrogate(spike(), &v, &CheckConfig::default()).unwrap();
    // Finite differences see a step function: zero almost everywhere, so they disagree.
    assert!(check_gradients(
        |t, x| t.map(spike(), x[0]),
        std::slice::from_ref(&v),
        &CheckConfig::default()
    )
    .is_err());
    let mut t = Tape::<f32>::new();
    let x = t.leaf(v.cast());
    let s = t.map(spike(), x);
    assert_eq!(t.value(s).data(), &[0.0, 0.0, 1.0, 1.0]);
    let total = t.sum(s);
    t.backward(total);
    let g = t.grad(x).unwrap().data();
    assert!(
        (g[1] - 1.0 / 1.5f32.powi(2)).abs() < 1e-6,
        "surrogate at v = 0.95: {}",
        g[1]
    );
}

/// Rounds to the nearest integer; exact derivative 0 almost everywhere.
struct Round;
impl Pointwise for Round {
    fn name(&self) -> &'static str {
        "round"
    }
    fn f(&self, x: f64) -> f64 {
        x.round()
    }
    fn df(&self, _x: f64, _y: f64) -> f64 {
        0.0
    }
}

/// A straight-through estimator: replaces the VJP of every `round` node by the identity.
struct StraightThrough {
    replaced: usize,
}
impl BackwardHooks<f32> for StraightThrough {
    fn override_vjp(
        &mut self,
        node: &NodeView<'_, f32>,
        dy: &Tensor<f32>,
        dx: &mut GradSlots<'_, f32>,
    ) -> bool {
        if node.name != "round" {
            return false;
        }
        self.replaced += 1;
        if let Some(g) = dx.slot_data(0) {
            g.iter_mut().zip(dy.data()).for_each(|(g, &d)| *g += d);
        }
        true
    }
}

#[test]
fn a_hook_replaces_a_vjp() {
    let mut t = Tape::<f32>::new();
    let x = t.leaf(Tensor::from_vec([3], vec![0.4, 1.6, -2.2]));
    let r = t.map(Round, x);
    let y = t.scale(r, 3.0);
    let loss = t.sum(y);
    t.backward(loss);
    assert_eq!(
        t.grad(x).unwrap().data(),
        &[0.0, 0.0, 0.0],
        "without the hook, round blocks"
    );
    let mut ste = StraightThrough { replaced: 0 };
    t.backward_with(loss, &mut ste);
    assert_eq!(ste.replaced, 1);
    assert_eq!(t.grad(x).unwrap().data(), &[3.0, 3.0, 3.0]);
}

/// Records the gradient of one node when it is complete.
struct Spy {
    target: Var,
    seen: Option<Tensor<f64>>,
}
impl BackwardHooks<f64> for Spy {
    fn on_grad(&mut self, node: &NodeView<'_, f64>, grad: &mut Tensor<f64>) {
        if node.var == self.target {
            self.seen = Some(grad.clone());
        }
    }
}

#[test]
fn a_hook_reads_an_intermediate_gradient_and_retain_grad_keeps_it() {
    let mut t = Tape::<f64>::new();
    let x = t.leaf(Tensor::from_vec([3], vec![0.5, -1.0, 2.0]));
    let h = t.scale(x, 3.0); // h = 3x
    let h2 = t.square(h);
    let y = t.mul(h2, h); // y = h³
    let loss = t.sum(y);
    let mut spy = Spy {
        target: h,
        seen: None,
    };
    t.backward_with(loss, &mut spy);
    let want: Vec<f64> = [1.5f64, -3.0, 6.0].iter().map(|h| 3.0 * h * h).collect(); // ∂L/∂h = 3h²
    assert_eq!(spy.seen.as_ref().unwrap().data(), &want[..]);
    assert!(
        t.grad(h).is_none(),
        "intermediate gradients are dropped by default"
    );
    t.retain_grad(h);
    t.backward(loss);
    assert_eq!(t.grad(h).unwrap().data(), &want[..]);
    assert_eq!(
        t.grad(x).unwrap().data(),
        &want.iter().map(|g| 3.0 * g).collect::<Vec<_>>()[..]
    );
}

#[test]
fn frozen_parameters_stay_bit_identical_through_adam() {
    let mut params = ParamStore::<f32>::new();
    let w1 = params.add(
        "layer1.w",
        Tensor::from_fn([3, 4], |i| (i as f32 * 0.7).sin()),
    );
    let w2 = params.add(
        "layer2.w",
        Tensor::from_fn([4, 1], |i| (i as f32 * 1.3).cos()),
    );
    params.freeze(w1);
    let before = params.get(w1).clone();
    let mut opt = Optimizer::new(Adam::default());
    let mut tape = Tape::new();
    let w2_start = params.get(w2).clone();
    for _ in 0..5 {
        tape.clear();
        let x = tape.constant(Tensor::from_fn([2, 3], |i| i as f32 - 2.0));
        let (a, b) = (params.var(&mut tape, w1), params.var(&mut tape, w2));
        let h = tape.matmul(x, a);
        let h = tape.tanh(h);
        let y = tape.matmul(h, b);
        let loss = tape.square(y);
        let loss = tape.sum(loss);
        let grads = Backprop.assign_credit(&mut tape, loss.into(), &params);
        assert!(
            grads.get(w1).is_none(),
            "a frozen parameter is a constant on the tape"
        );
        opt.step(0.1, &mut params, &grads).unwrap();
    }
    let bits = |t: &Tensor<f32>| t.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(params.get(w1)), bits(&before));
    assert_ne!(params.get(w2), &w2_start, "the trainable layer did move");
}

/// A two-layer regression `y = tanh(x W1 + b1) W2 + b2` onto a smooth teacher.
struct Regression {
    x: Tensor<f32>,
    t: Tensor<f32>,
}

impl Regression {
    fn new() -> Self {
        let n = 64;
        let x = Tensor::from_fn([n, 3], |i| ((i * 37 % 101) as f32 / 50.0) - 1.0);
        let t = Tensor::from_fn([n, 2], |i| {
            let (r, c) = (i / 2, i % 2);
            let xr = &x.data()[r * 3..r * 3 + 3];
            if c == 0 {
                (xr[0] + 0.5 * xr[1]).sin()
            } else {
                xr[2] * xr[0] - 0.3 * xr[1]
            }
        });
        Regression { x, t }
    }

    fn params() -> ParamStore<f32> {
        let mut p = ParamStore::new();
        // Deterministic pseudo-random values in [-1, 1) (Knuth's multiplicative hash).
        let unit = |i: usize| (((i * 2654435761) >> 7) % 1000) as f32 / 500.0 - 1.0;
        p.add("hidden.w", Tensor::from_fn([3, 32], |i| unit(i) * 0.8));
        p.add("hidden.b", Tensor::zeros([32]));
        p.add("out.w", Tensor::from_fn([32, 2], |i| unit(i + 97) * 0.25));
        p.add("out.b", Tensor::zeros([2]));
        p
    }

    fn loss(&self, tape: &mut Tape<f32>, p: &ParamStore<f32>) -> Var {
        tape.clear();
        let x = tape.constant(self.x.clone());
        let t = tape.constant(self.t.clone());
        let v: Vec<Var> = p.ids().map(|id| p.var(tape, id)).collect();
        let h = tape.linear(x, v[0], v[1]);
        let h = tape.tanh(h);
        let y = tape.linear(h, v[2], v[3]);
        let e = tape.sub(y, t);
        let e = tape.square(e);
        tape.mean(e)
    }

    /// Trains with `rule`; returns (first loss, last loss, hidden-weight gradient at step 0).
    fn train(&self, rule: &mut dyn LearningRule<f32>) -> (f32, f32, Tensor<f32>) {
        let mut p = Self::params();
        let mut opt = Optimizer::new(Adam::default());
        let mut tape = Tape::new();
        let (mut first, mut last, mut g0) = (0.0, 0.0, None);
        for step in 0..600 {
            let loss = self.loss(&mut tape, &p);
            last = tape.value(loss).item();
            let grads = rule.assign_credit(&mut tape, loss.into(), &p);
            if step == 0 {
                first = last;
                g0 = grads.get(ParamId(0)).cloned();
            }
            opt.step(0.01, &mut p, &grads).unwrap();
        }
        (first, last, g0.unwrap())
    }
}

#[test]
fn feedback_alignment_and_backprop_both_learn_but_differ() {
    let task = Regression::new();
    let (bp_first, bp_last, bp_g) = task.train(&mut Backprop);
    let (fa_first, fa_last, fa_g) = task.train(&mut FeedbackAlignment::new(2024));
    eprintln!("backprop {bp_first} → {bp_last}; feedback alignment {fa_first} → {fa_last}");
    assert_eq!(bp_first, fa_first, "same model, same start");
    assert!(
        bp_last * 10.0 <= bp_first,
        "backprop: {bp_first} → {bp_last}"
    );
    assert!(
        fa_last * 10.0 <= fa_first,
        "feedback alignment: {fa_first} → {fa_last}"
    );
    let rel = (fa_g.max_abs_diff(&bp_g))
        / bp_g
            .data()
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs() as f64));
    assert!(
        rel > 0.1,
        "hidden-layer updates must differ (relative difference {rel})"
    );
}

#[test]
fn param_store_safetensors_round_trip_is_bit_exact() {
    let mut p = ParamStore::<f32>::new();
    p.add(
        "cortex.unet.down0.conv0",
        Tensor::from_fn([4, 2, 3, 3], |i| (i as f32 * 0.123).sin() * 1e-3),
    );
    p.add(
        "cortex.scope.bias",
        Tensor::from_vec([3], vec![f32::MAX, -0.0, f32::from_bits(1)]),
    );
    let frozen = p.add("retina.gain", Tensor::scalar(1.0 / 3.0));
    p.freeze(frozen);
    let path =
        std::env::temp_dir().join(format!("autodiff-ext-{}.safetensors", std::process::id()));
    let meta = BTreeMap::from([("step".to_string(), "100000".to_string())]);
    p.save_safetensors(&path, &meta).unwrap();
    let (q, m) = ParamStore::<f32>::load_safetensors(&path).unwrap();
    let mut r = ParamStore::<f32>::new();
    for id in p.ids() {
        r.add(p.name(id), Tensor::zeros(p.get(id).shape()));
    }
    r.load_into(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(m, meta);
    let bits = |t: &Tensor<f32>| t.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for id in p.ids() {
        assert_eq!(
            (q.name(id), q.is_trainable(id)),
            (p.name(id), p.is_trainable(id))
        );
        assert_eq!(bits(q.get(id)), bits(p.get(id)), "{}", p.name(id));
        assert_eq!(bits(r.get(id)), bits(p.get(id)), "{}", p.name(id));
    }
}
