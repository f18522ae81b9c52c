//! A learning rule written outside the library, in this one file: sign symmetry (Liao, Leibo
//! & Poggio 2016, AAAI): errors travel back through `sign(W)·mean|W|` instead of `W`, so the
//! feedback shares only the signs of the forward weights. Nothing in `autodiff` was changed
//! to add it: it implements [`LearningRule`] with a [`BackwardHooks`] override, as
//! `autodiff::learn::FeedbackAlignment` does.

use autodiff::learn::{Backprop, LearningRule, Objective, ParamGrads};
use autodiff::optim::{Adam, Optimizer};
use autodiff::{
    BackwardHooks, Float, GradSlots, NodeKind, NodeView, ParamId, ParamStore, Tape, Tensor, Var,
};

/// Sign-symmetric feedback for every parameter that an op declares as its weight.
struct SignSymmetry;

impl<T: Float> BackwardHooks<T> for SignSymmetry {
    fn override_vjp(
        &mut self,
        node: &NodeView<'_, T>,
        dy: &Tensor<T>,
        dx: &mut GradSlots<'_, T>,
    ) -> bool {
        let is_weight = |i: usize| {
            node.weight_inputs().contains(&i)
                && matches!(node.input_kinds.get(i), Some(NodeKind::Param(_)))
        };
        if !(0..dx.len()).any(is_weight) {
            return false;
        }
        let wanted: Vec<bool> = (0..dx.len()).map(|i| dx.wants(i)).collect();
        // The weight's own gradient from the real inputs …
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w && is_weight(i));
        }
        node.backward_with_inputs(node.input_values, dy, dx);
        // … every other input's through sign(W)·mean|W|.
        let signed: Vec<Tensor<T>> = (0..wanted.len())
            .map(|i| {
                let v = node.input_values[i];
                if !is_weight(i) {
                    return v.clone();
                }
                let mean_abs =
                    v.data().iter().map(|x| x.as_f64().abs()).sum::<f64>() / v.numel() as f64;
                Tensor::from_fn(v.shape(), |k| {
                    T::of(v.data()[k].as_f64().signum() * mean_abs)
                })
            })
            .collect();
        let refs: Vec<&Tensor<T>> = signed.iter().collect();
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w && !is_weight(i));
        }
        node.backward_with_inputs(&refs, dy, dx);
        for (i, &w) in wanted.iter().enumerate() {
            dx.set_wanted(i, w);
        }
        true
    }
}

impl<T: Float> LearningRule<T> for SignSymmetry {
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        tape.backward_with(objective.loss, self);
        grads.fill_from_tape(tape);
    }
}

/// `mean (tanh(x·W1)·W2 − t)²` on 48 samples of a smooth 2-D target.
fn loss(tape: &mut Tape<f64>, p: &ParamStore<f64>) -> Var {
    tape.clear();
    let x = Tensor::from_fn([48, 2], |i| ((i * 37 % 97) as f64 / 48.0) - 1.0);
    let t = Tensor::from_fn([48, 1], |s| {
        (2.0 * x.data()[2 * s]).sin() * x.data()[2 * s + 1]
    });
    let (x, t) = (tape.constant(x), tape.constant(t));
    let (w1, w2) = (p.var(tape, ParamId(0)), p.var(tape, ParamId(1)));
    let h = tape.matmul(x, w1);
    let h = tape.tanh(h);
    let y = tape.matmul(h, w2);
    let e = tape.sub(y, t);
    let e = tape.square(e);
    tape.mean(e)
}

fn params() -> ParamStore<f64> {
    let mut p = ParamStore::new();
    p.add(
        "w1",
        Tensor::from_fn([2, 24], |i| ((i * 53 % 23) as f64 - 11.0) / 12.0),
    );
    p.add(
        "w2",
        Tensor::from_fn([24, 1], |i| ((i * 29 % 17) as f64 - 8.0) / 30.0),
    );
    p
}

#[test]
fn a_rule_from_outside_the_library_trains_and_is_not_backprop() {
    let mut p = params();
    let mut tape = Tape::new();
    let l = loss(&mut tape, &p);
    let ss = SignSymmetry.assign_credit(&mut tape, l.into(), &p);
    let l = loss(&mut tape, &p);
    let bp = Backprop.assign_credit(&mut tape, l.into(), &p);
    let hidden = ss
        .get(ParamId(0))
        .unwrap()
        .max_abs_diff(bp.get(ParamId(0)).unwrap());
    assert!(
        hidden > 1e-3,
        "hidden-layer update equals backprop's ({hidden})"
    );
    let mut opt = Optimizer::new(Adam::default());
    let first = tape.value(l).item();
    let mut rule: Box<dyn LearningRule<f64>> = Box::new(SignSymmetry);
    for _ in 0..500 {
        let l = loss(&mut tape, &p);
        let g = rule.assign_credit(&mut tape, l.into(), &p);
        opt.step(0.02, &mut p, &g).unwrap();
    }
    let l = loss(&mut tape, &p);
    let last = tape.value(l).item();
    eprintln!("sign symmetry: loss {first:.4} → {last:.5}");
    assert!(last * 10.0 <= first, "loss {first} → {last}");
}
