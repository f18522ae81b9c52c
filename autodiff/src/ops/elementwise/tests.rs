//! Tests of the element-wise ops: values against std, gradients against f64 central differences, and the parallel path.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use proptest::prelude::*;

fn unary(name: &str, t: &mut Tape<f64>, x: Var) -> Var {
    match name {
        "relu" => t.relu(x),
        "neg" => t.neg(x),
        "scale" => t.scale(x, -1.7),
        "add_scalar" => t.add_scalar(x, 0.4),
        "square" => t.square(x),
        "sqrt" => t.sqrt(x),
        "exp" => t.exp(x),
        "log" => t.log(x),
        "abs" => t.abs(x),
        "sigmoid" => t.sigmoid(x),
        "tanh" => t.tanh(x),
        "softplus" => t.softplus(x),
        "pow" => t.pow(x, 3.0),
        other => panic!("no unary op {other}"),
    }
}

fn binary(name: &str, t: &mut Tape<f64>, a: Var, b: Var) -> Var {
    match name {
        "add" => t.add(a, b),
        "sub" => t.sub(a, b),
        "mul" => t.mul(a, b),
        "div" => t.div(a, b),
        other => panic!("no binary op {other}"),
    }
}

const UNARY_ANY: &[&str] = &[
    "neg",
    "scale",
    "add_scalar",
    "square",
    "exp",
    "sigmoid",
    "tanh",
    "softplus",
    "pow",
];

proptest! {
    #![proptest_config(st::config())]

    #[test]
    fn smooth_unary_ops(x in (1usize..=3).prop_flat_map(st::tensor)) {
        for &name in UNARY_ANY {
            let r = check_gradients(|t, v| unary(name, t, v[0]), std::slice::from_ref(&x), &CheckConfig::default());
            prop_assert!(r.is_ok(), "{name}: {}", r.unwrap_err());
        }
    }

    #[test]
    fn kinked_unary_ops(x in st::dims(2).prop_flat_map(|d| st::tensor_away_from(d, 0.0, 1e-3))) {
        for name in ["relu", "abs"] {
            let r = check_gradients(|t, v| unary(name, t, v[0]), std::slice::from_ref(&x), &CheckConfig::default());
            prop_assert!(r.is_ok(), "{name}: {}", r.unwrap_err());
        }
    }

    #[test]
    fn positive_domain_ops(x in st::tensor(2)) {
        // sqrt, log and pow with a fractional exponent need x > 0: map [-2, 2] to [0.2, 2.2].
        let x = Tensor::from_fn(x.shape(), |i| x.data()[i].abs() + 0.2);
        for name in ["sqrt", "log"] {
            let r = check_gradients(|t, v| unary(name, t, v[0]), std::slice::from_ref(&x), &CheckConfig::default());
            prop_assert!(r.is_ok(), "{name}: {}", r.unwrap_err());
        }
        let r = check_gradients(|t, v| t.pow(v[0], -1.5), &[x], &CheckConfig::default());
        prop_assert!(r.is_ok(), "pow -1.5: {}", r.unwrap_err());
    }

    #[test]
    fn binary_ops((a, b) in st::dims(3).prop_flat_map(|d| (st::tensor_of(d.clone()), st::tensor_of(d)))) {
        // Keep the divisor away from 0: |b| ≥ 0.3.
        let b = Tensor::from_fn(b.shape(), |i| { let v = b.data()[i]; v.signum() * (v.abs() + 0.3) });
        for name in ["add", "sub", "mul", "div"] {
            let r = check_gradients(|t, v| binary(name, t, v[0], v[1]), &[a.clone(), b.clone()], &CheckConfig::default());
            prop_assert!(r.is_ok(), "{name}: {}", r.unwrap_err());
        }
    }
}

#[test]
fn same_input_twice_accumulates() {
    // x ⊙ x and x / x exercise two slots writing into one gradient.
    let x = Tensor::from_vec([3], vec![0.7, -1.2, 1.9]);
    for name in ["mul", "div", "add", "sub"] {
        check_gradients(
            |t, v| binary(name, t, v[0], v[0]),
            std::slice::from_ref(&x),
            &CheckConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn large_tensors_take_the_parallel_path() {
    let n = PAR_MIN_LEN + 3;
    let a = Tensor::from_fn([n], |i| (i as f64 * 0.01).sin());
    let b = Tensor::from_fn([n], |i| 1.5 + (i as f64 * 0.02).cos());
    let cfg = CheckConfig::default();
    for name in ["add", "mul", "div"] {
        check_gradients(
            |t, v| binary(name, t, v[0], v[1]),
            &[a.clone(), b.clone()],
            &cfg,
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    // Keep relu's input at least 1e-3 away from its kink (sin(0) = 0 would sit on it).
    let a = Tensor::from_fn([n], |i| a.data()[i] + 1e-3f64.copysign(a.data()[i]));
    check_gradients(|t, v| unary("relu", t, v[0]), &[a], &cfg)
        .unwrap_or_else(|e| panic!("relu: {e}"));
}

#[test]
fn values_match_std() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::from_vec([4], vec![-30.0, -0.5, 0.0, 40.0]));
    let s = t.sigmoid(x);
    let p = t.softplus(x);
    let r = t.relu(x);
    let want = [
        1.0 / (1.0 + 30f64.exp()),
        1.0 / (1.0 + 0.5f64.exp()),
        0.5,
        1.0,
    ];
    for (&got, want) in t.value(s).data().iter().zip(want) {
        assert!((got as f64 - want).abs() <= 1e-7 * want, "{got} vs {want}");
    }
    assert!((t.value(p).data()[3] - 40.0).abs() < 1e-6 && t.value(p).data()[0] > 0.0);
    assert_eq!(t.value(r).data(), &[0.0, 0.0, 0.0, 40.0]);
}

#[test]
#[should_panic(expected = "mul: shapes differ, lhs (2, 3) vs rhs (3, 2)")]
fn shape_mismatch_names_op_and_shapes() {
    let mut t = Tape::<f32>::new();
    let a = t.constant(Tensor::zeros([2, 3]));
    let b = t.constant(Tensor::zeros([3, 2]));
    t.mul(a, b);
}
