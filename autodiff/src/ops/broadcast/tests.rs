//! Tests of the broadcast and reshape ops: forward values and gradients against f64 central differences.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use proptest::prelude::*;

/// A target shape (rank 1..=4) and an operand shape that broadcasts to it: each axis kept or
/// set to 1, and some leading axes dropped.
fn pair() -> impl Strategy<Value = (Vec<usize>, Vec<usize>)> {
    (1usize..=4)
        .prop_flat_map(st::dims)
        .prop_flat_map(|t| {
            let r = t.len();
            (Just(t), proptest::collection::vec(any::<bool>(), r), 0..=r)
        })
        .prop_map(|(t, keep, drop)| {
            let y: Vec<usize> = t
                .iter()
                .zip(&keep)
                .map(|(&d, &k)| if k { d } else { 1 })
                .collect();
            (t, y[drop..].to_vec())
        })
}

fn tensors() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>)> {
    pair().prop_flat_map(|(t, y)| (st::tensor_of(t), st::tensor_of(y)))
}

proptest! {
    #![proptest_config(st::config())]

    #[test]
    fn broadcast_to_gradient((x, y) in tensors()) {
        let shape = x.shape();
        let r = check_gradients(|t, v| t.broadcast_to(v[0], shape), &[y], &CheckConfig::default());
        prop_assert!(r.is_ok(), "broadcast_to: {}", r.unwrap_err());
    }

    #[test]
    fn add_broadcast_gradient((x, y) in tensors()) {
        let r = check_gradients(|t, v| t.add_broadcast(v[0], v[1]), &[x, y], &CheckConfig::default());
        prop_assert!(r.is_ok(), "add_broadcast: {}", r.unwrap_err());
    }

    #[test]
    fn mul_broadcast_gradient((x, y) in tensors()) {
        let r = check_gradients(|t, v| t.mul_broadcast(v[0], v[1]), &[x, y], &CheckConfig::default());
        prop_assert!(r.is_ok(), "mul_broadcast: {}", r.unwrap_err());
    }

    #[test]
    fn strided_ops_match_materialised_broadcast((x, y) in tensors()) {
        let mut t = Tape::<f64>::new();
        let (xv, yv) = (t.constant(x.clone()), t.constant(y));
        let yb = t.broadcast_to(yv, x.shape());
        let (a, b) = (t.add_broadcast(xv, yv), t.add(xv, yb));
        prop_assert_eq!(t.value(a), t.value(b));
        let (a, b) = (t.mul_broadcast(xv, yv), t.mul(xv, yb));
        prop_assert_eq!(t.value(a), t.value(b));
    }

    #[test]
    fn reshape_gradient(x in st::tensor(3)) {
        let d = x.dims().to_vec();
        let r = check_gradients(|t, v| {
            let flat = t.reshape(v[0], [d[0] * d[1], d[2]]);
            t.square(flat) // a non-linear consumer, so a wrong routing would show
        }, &[x], &CheckConfig::default());
        prop_assert!(r.is_ok(), "reshape: {}", r.unwrap_err());
    }
}

#[test]
fn per_channel_bias_layout() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([2, 3, 2, 2]));
    let b = t.constant(Tensor::from_vec([3, 1, 1], vec![1.0, 2.0, 3.0]));
    let y = t.add_broadcast(x, b);
    let v = t.value(y).data();
    assert_eq!(
        &v[..12],
        &[1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0, 3.0, 3.0, 3.0, 3.0]
    );
    assert_eq!(&v[12..], &v[..12]);
}

#[test]
#[should_panic(expected = "add_broadcast: cannot broadcast (3,) to (2, 3, 4)")]
fn bad_broadcast_names_op_and_shapes() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([2, 3, 4]));
    let y = t.constant(Tensor::zeros([3]));
    t.add_broadcast(x, y);
}

#[test]
#[should_panic(expected = "reshape: (2, 3) cannot become (4,)")]
fn bad_reshape_panics() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([2, 3]));
    t.reshape(x, [4]);
}
