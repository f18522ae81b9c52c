//! Tests of the channel ops: gradient checks over proptest shapes, fresh and accumulated
//! gradient buffers, and plain-loop references on cases split across parallel tasks.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use proptest::prelude::*;

/// `(B, C, rest…)` dims of rank 2..=4 with the given channel count.
fn dims_with(c: usize) -> impl Strategy<Value = Vec<usize>> {
    (1usize..=3, proptest::collection::vec(1usize..=4, 0..=2)).prop_map(move |(b, rest)| {
        let mut d = vec![b, c];
        d.extend(rest);
        d
    })
}

fn set_channels(d: &[usize], c: usize) -> Vec<usize> {
    let mut d = d.to_vec();
    d[1] = c;
    d
}

proptest! {
    #![proptest_config(st::config())]

    #[test]
    fn concat_and_slice_gradients(
        (a, b, c) in (1usize..=3).prop_flat_map(dims_with).prop_flat_map(|d| (
            st::tensor_of(d.clone()), st::tensor_of(set_channels(&d, 2)), st::tensor_of(set_channels(&d, 1)),
        )),
        start in 0usize..4, len in 1usize..4,
    ) {
        let r = check_gradients(|t, v| t.concat(v), &[a.clone(), b.clone(), c.clone()], &CheckConfig::default());
        prop_assert!(r.is_ok(), "concat {:?}: {}", a.shape(), r.unwrap_err());
        let total = a.dims()[1] + 3;
        let start = start.min(total - 1);
        let len = len.min(total - start);
        let r = check_gradients(|t, v| { let x = t.concat(v); t.slice(x, start, len) }, &[a, b, c], &CheckConfig::default());
        prop_assert!(r.is_ok(), "slice {start}+{len}: {}", r.unwrap_err());
    }

    #[test]
    fn add_channel_bias_gradients(
        (x, b) in (1usize..=4).prop_flat_map(|c| (dims_with(c).prop_flat_map(st::tensor_of), st::tensor_of(vec![c]))),
    ) {
        let r = check_gradients(|t, v| t.add_channel_bias(v[0], v[1]), &[x, b], &CheckConfig::default());
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    /// Inputs used twice: the later op's backward gets fresh gradient buffers (written
    /// over; NaN-filled under test, so a missed element fails), the earlier one adds.
    #[test]
    fn concat_and_bias_gradients_into_shared_inputs(
        (x, b) in (1usize..=3).prop_flat_map(|c| (dims_with(c).prop_flat_map(st::tensor_of), st::tensor_of(vec![c]))),
    ) {
        let r = check_gradients(
            |t, v| {
                let y = t.add_channel_bias(v[0], v[1]);
                let z = t.add_channel_bias(v[0], v[1]);
                let yz = t.mul(y, z);
                t.concat(&[v[0], yz, v[0]])
            },
            &[x.clone(), b],
            &CheckConfig::default(),
        );
        prop_assert!(r.is_ok(), "{:?}: {}", x.shape(), r.unwrap_err());
    }

    #[test]
    fn channel_dot_and_outer_gradients(
        (v, c, p) in (1usize..=4, any::<bool>()).prop_flat_map(|(n, bcast)| dims_with(n).prop_flat_map(move |d| {
            let mut cd = d.clone();
            if bcast { cd[0] = 1; }
            (st::tensor_of(d.clone()), st::tensor_of(cd), st::tensor_of(set_channels(&d, 1)))
        })),
    ) {
        let r = check_gradients(|t, x| t.channel_dot(x[0], x[1]), &[v.clone(), c.clone()], &CheckConfig::default());
        prop_assert!(r.is_ok(), "channel_dot {:?} {:?}: {}", v.shape(), c.shape(), r.unwrap_err());
        let r = check_gradients(|t, x| t.channel_outer(x[0], x[1]), &[p.clone(), c.clone()], &CheckConfig::default());
        prop_assert!(r.is_ok(), "channel_outer {:?} {:?}: {}", p.shape(), c.shape(), r.unwrap_err());
    }

    #[test]
    fn normalize_channels_gradients(
        x in (1usize..=4).prop_flat_map(dims_with).prop_flat_map(|d| st::tensor_away_from(d, 0.0, 0.2)),
        eps in prop_oneof![Just(1e-5), Just(0.3)],
    ) {
        let r = check_gradients(|t, v| t.normalize_channels(v[0], eps), &[x], &CheckConfig::default());
        prop_assert!(r.is_ok(), "eps {eps}: {}", r.unwrap_err());
    }
}

#[test]
fn values_by_hand() {
    let mut t = Tape::<f64>::new();
    // v (1, 2, 1, 2), c broadcast (1, 2, 1, 2): dot = [1·5 + 3·7, 2·6 + 4·8].
    let v = t.constant(Tensor::from_vec([1, 2, 1, 2], vec![1., 2., 3., 4.]));
    let c = t.constant(Tensor::from_vec([1, 2, 1, 2], vec![5., 6., 7., 8.]));
    let d = t.channel_dot(v, c);
    assert_eq!(t.value(d).data(), &[26., 44.]);
    let o = t.channel_outer(d, c);
    assert_eq!(t.value(o).data(), &[130., 264., 182., 352.]);
    let x = t.constant(Tensor::from_vec([1, 2, 1, 1], vec![3., 4.]));
    let n = t.normalize_channels(x, 0.0);
    assert!(
        t.value(n)
            .max_abs_diff(&Tensor::from_vec([1, 2, 1, 1], vec![0.6, 0.8]))
            < 1e-15
    );
    let b = t.constant(Tensor::from_vec([2], vec![10., 20.]));
    let y = t.add_channel_bias(v, b);
    assert_eq!(t.value(y).data(), &[11., 12., 23., 24.]);
    let cat = t.concat(&[v, d, o]);
    assert_eq!(t.shape(cat), Shape::new(&[1, 5, 1, 2]));
    assert_eq!(
        t.value(cat).data(),
        &[1., 2., 3., 4., 26., 44., 130., 264., 182., 352.]
    );
    let s = t.slice(v, 1, 1);
    assert_eq!(t.value(s).data(), &[3., 4.]);
    // (N, 2) point sets: axis 1 is the coordinate.
    let pts = t.constant(Tensor::from_vec([3, 2], vec![1., 2., 3., 4., 5., 6.]));
    let ys = t.slice(pts, 1, 1);
    assert_eq!(t.value(ys).data(), &[2., 4., 6.]);
}

#[test]
fn large_concat_and_bias_match_plain_loops() {
    // Big enough for several parallel tasks (MIN_TASK_ELEMS); integer values keep every
    // sum exact, so the results must agree exactly whatever the summation order.
    let (bn, ca, cb, inner) = (3, 5, 2, 70 * 90);
    let a = Tensor::from_fn([bn, ca, 70, 90], |i| ((i * 37) % 19) as f64 - 9.0);
    let b = Tensor::from_fn([bn, cb, 70, 90], |i| ((i * 11) % 23) as f64 - 11.0);
    let bias = Tensor::from_vec([ca + cb], (0..ca + cb).map(|k| k as f64).collect());
    let mut t = Tape::<f64>::new();
    let (av, bv, biasv) = (t.leaf(a.clone()), t.leaf(b.clone()), t.leaf(bias.clone()));
    let cat = t.concat(&[av, bv]);
    let y = t.add_channel_bias(cat, biasv);
    let c = ca + cb;
    let at = |bi: usize, k: usize, q: usize| {
        if k < ca {
            a.data()[(bi * ca + k) * inner + q]
        } else {
            b.data()[(bi * cb + k - ca) * inner + q]
        }
    };
    let want = Tensor::from_fn([bn, c, 70, 90], |f| {
        let (bi, k, q) = (f / (c * inner), (f / inner) % c, f % inner);
        at(bi, k, q) + k as f64
    });
    assert_eq!(t.value(y).data(), want.data());
    let dy = Tensor::from_fn(t.shape(y), |i| ((i * 29) % 13) as f64 - 6.0);
    t.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
    let mut gb = vec![0.0; c];
    for (p, plane) in dy.data().chunks_exact(inner).enumerate() {
        gb[p % c] += plane.iter().sum::<f64>();
    }
    assert_eq!(t.grad(biasv).unwrap().data(), &gb[..]);
    let pick = |bi: usize, k: usize| &dy.data()[(bi * c + k) * inner..][..inner];
    let ga: Vec<f64> = (0..bn)
        .flat_map(|bi| (0..ca).flat_map(move |k| pick(bi, k).to_vec()))
        .collect();
    let gbb: Vec<f64> = (0..bn)
        .flat_map(|bi| (ca..c).flat_map(move |k| pick(bi, k).to_vec()))
        .collect();
    assert_eq!(t.grad(av).unwrap().data(), &ga[..]);
    assert_eq!(t.grad(bv).unwrap().data(), &gbb[..]);
}

#[test]
fn zero_vector_normalises_to_zero_with_finite_gradient() {
    let mut t = Tape::<f64>::new();
    let x = t.leaf(Tensor::zeros([1, 3, 1, 1]));
    let y = t.normalize_channels(x, 1e-5);
    assert_eq!(t.value(y).data(), &[0., 0., 0.]);
    t.backward_from(&[(y, Tensor::full([1, 3, 1, 1], 1.0))], &mut crate::NoHooks);
    // Only the 1/(‖x‖ + eps) term survives: ∂y/∂x = I / eps.
    assert!(
        t.grad(x)
            .unwrap()
            .max_abs_diff(&Tensor::full([1, 3, 1, 1], 1e5))
            < 1e-9
    );
}

#[test]
#[should_panic(expected = "concat: shapes (2, 3, 4) and (2, 1, 5) differ outside axis 1")]
fn concat_mismatch_panics() {
    let mut t = Tape::<f32>::new();
    let a = t.constant(Tensor::zeros([2, 3, 4]));
    let b = t.constant(Tensor::zeros([2, 1, 5]));
    t.concat(&[a, b]);
}

#[test]
#[should_panic(expected = "channel_dot: shapes (2, 3, 4, 4) and (2, 2, 4, 4) do not fit")]
fn channel_dot_mismatch_panics() {
    let mut t = Tape::<f32>::new();
    let a = t.constant(Tensor::zeros([2, 3, 4, 4]));
    let b = t.constant(Tensor::zeros([2, 2, 4, 4]));
    t.channel_dot(a, b);
}

#[test]
#[should_panic(expected = "add_channel_bias: bias (2,) does not fit input (1, 3, 2)")]
fn bias_mismatch_panics() {
    let mut t = Tape::<f32>::new();
    let a = t.constant(Tensor::zeros([1, 3, 2]));
    let b = t.constant(Tensor::zeros([2]));
    t.add_channel_bias(a, b);
}

#[test]
#[should_panic(expected = "slice: channels 2..5 out of range for input (1, 4, 2)")]
fn slice_out_of_range_panics() {
    let mut t = Tape::<f32>::new();
    let a = t.constant(Tensor::zeros([1, 4, 2]));
    t.slice(a, 2, 3);
}
