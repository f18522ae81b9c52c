//! Tests of the gradient checker: correct gradients pass, wrong ones are caught, masked inputs stay constant, surrogate gradients.

use super::*;
use crate::op::{BackwardCx, GradSlots, Op};

/// y = x ⊙ w, with a backward that (wrongly) transposes nothing but swaps two elements:
/// invisible under a plain sum, caught by the random reduction.
struct Permuted;
impl Op<f64> for Permuted {
    fn name(&self) -> &'static str {
        "permuted_test"
    }
    fn output_shape(&self, inputs: &[&Tensor<f64>]) -> Shape {
        inputs[0].shape()
    }
    fn forward(&mut self, inputs: &[&Tensor<f64>], out: &mut Tensor<f64>) {
        out.data_mut().copy_from_slice(inputs[0].data());
    }
    fn backward(&self, cx: &BackwardCx<'_, f64>, dx: &mut GradSlots<'_, f64>) {
        if let Some(g) = dx.slot_data(0) {
            for (g, &d) in g.iter_mut().zip(cx.dy.data().iter().rev()) {
                *g += d;
            }
        }
    }
}

#[test]
fn correct_gradient_passes() {
    let x = Tensor::from_vec([2, 3], vec![0.1, -0.5, 1.5, 2.0, -1.0, 0.3]);
    let rep = check_gradients(
        |t, v| t.map(Sq, v[0]),
        std::slice::from_ref(&x),
        &CheckConfig::default(),
    )
    .unwrap();
    assert_eq!(rep.checked, 6);
    assert!(rep.max_rel_err < 1e-8, "{rep:?}");
}

#[test]
fn permuted_backward_is_caught_and_reported() {
    let x = Tensor::from_fn([3, 2], |i| i as f64 * 0.3 - 0.7);
    let err =
        check_gradients(|t, v| t.apply(Permuted, v), &[x], &CheckConfig::default()).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(err, CheckError::Mismatch { failed: 6, .. }),
        "{text}"
    );
    assert!(text.contains("input 0 (3, 2) [flat"), "{text}");
}

#[test]
fn probes_catch_a_wrong_gradient_on_large_inputs() {
    let x = Tensor::from_fn([10, 10], |i| (i as f64 * 0.37).sin());
    let cfg = CheckConfig::default();
    let err =
        check_gradients(|t, v| t.apply(Permuted, v), std::slice::from_ref(&x), &cfg).unwrap_err();
    assert!(
        matches!(err, CheckError::Mismatch { checked: 6, .. }),
        "{err}"
    );
    let ok = check_gradients(|t, v| t.map(Sq, v[0]), &[x], &cfg).unwrap();
    assert_eq!(ok.checked, 6);
}

#[test]
fn masked_inputs_are_constants() {
    let x = Tensor::from_vec([3], vec![0.5, -1.0, 2.0]);
    let m = Tensor::from_vec([3], vec![1.0, 0.0, 1.0]);
    let f = |t: &mut Tape<f64>, v: &[Var]| {
        assert_eq!(t.kind(v[1]), crate::NodeKind::Constant);
        let (a, b) = (t.value(v[0]).clone(), t.value(v[1]).clone());
        let val = Tensor::from_fn([3], |i| a.data()[i] * b.data()[i]);
        t.custom_vjp("mask_mul_test", v, val, |cx, dx| {
            if let Some(g) = dx.slot_data(0) {
                let (dy, m) = (cx.dy.data(), cx.inputs[1].data());
                g.iter_mut()
                    .zip(dy)
                    .zip(m)
                    .for_each(|((g, &d), &m)| *g += d * m);
            }
        })
    };
    let rep = check_inputs(f, &[x, m], &[true, false], &CheckConfig::default()).unwrap();
    assert_eq!(rep.checked, 3);
}

struct Sq;
impl Pointwise for Sq {
    fn name(&self) -> &'static str {
        "sq_test"
    }
    fn f(&self, x: f64) -> f64 {
        x * x
    }
    fn df(&self, x: f64, _y: f64) -> f64 {
        2.0 * x
    }
}

struct Step;
impl Pointwise for Step {
    fn name(&self) -> &'static str {
        "step_test"
    }
    fn f(&self, x: f64) -> f64 {
        f64::from(x > 0.0)
    }
    fn df(&self, x: f64, _y: f64) -> f64 {
        1.0 / (1.0 + x.abs()).powi(2)
    }
    fn exact(&self) -> bool {
        false
    }
}

#[test]
fn surrogate_matches_declared_df_but_not_finite_differences() {
    let x = Tensor::from_vec([4], vec![-1.5, -0.2, 0.3, 1.1]);
    let cfg = CheckConfig::default();
    assert_eq!(check_surrogate(Step, &x, &cfg).unwrap().checked, 8);
    assert!(check_gradients(|t, v| t.map(Step, v[0]), &[x], &cfg).is_err());
}
