//! Tests of the matrix product and the dense layer: values against a naive product, tall-skinny paths, and gradients.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use proptest::prelude::*;

fn operands() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>)> {
    st::dims(3).prop_flat_map(|d| {
        (
            st::tensor_of(vec![d[0], d[1]]),
            st::tensor_of(vec![d[1], d[2]]),
        )
    })
}

proptest! {
    #![proptest_config(st::config())]

    #[test]
    fn matmul_gradient((a, b) in operands()) {
        let r = check_gradients(|t, v| t.matmul(v[0], v[1]), &[a, b], &CheckConfig::default());
        prop_assert!(r.is_ok(), "matmul: {}", r.unwrap_err());
    }

    #[test]
    fn linear_gradient((x, w) in operands(), seed in any::<u64>()) {
        let n = w.dims()[1];
        let b = Tensor::from_fn([n], |i| ((seed >> (i % 60)) & 7) as f64 * 0.25 - 1.0);
        let r = check_gradients(|t, v| t.linear(v[0], v[1], v[2]), &[x, w, b], &CheckConfig::default());
        prop_assert!(r.is_ok(), "linear: {}", r.unwrap_err());
    }
}

#[test]
fn matmul_gradient_large_uses_probes() {
    // 12×9 and 9×11 exceed max_full_elems: exercises the probe path (and GEMM's kernels).
    let a = Tensor::from_fn([12, 9], |i| ((i * 7) % 13) as f64 / 6.5 - 1.0);
    let b = Tensor::from_fn([9, 11], |i| ((i * 5) % 17) as f64 / 8.5 - 1.0);
    check_gradients(
        |t, v| t.matmul(v[0], v[1]),
        &[a, b],
        &CheckConfig::default(),
    )
    .unwrap();
}

#[test]
fn values_match_naive_product() {
    let a = Tensor::from_fn([3, 4], |i| i as f32 * 0.5 - 2.0);
    let b = Tensor::from_fn([4, 2], |i| 1.0 - i as f32 * 0.25);
    let mut t = Tape::<f32>::new();
    let (av, bv) = (t.constant(a.clone()), t.constant(b.clone()));
    let y = t.matmul(av, bv);
    for i in 0..3 {
        for j in 0..2 {
            let want: f32 = (0..4)
                .map(|k| a.data()[i * 4 + k] * b.data()[k * 2 + j])
                .sum();
            assert!((t.value(y).data()[i * 2 + j] - want).abs() < 1e-5);
        }
    }
}

/// Deterministic values in [-1, 1) that are not a low-rank pattern.
fn pseudo(dims: [usize; 2], salt: usize) -> Tensor<f64> {
    Tensor::from_fn(dims, |i| {
        (((i * 2654435761 + salt * 40503) >> 7) % 2000) as f64 / 1000.0 - 1.0
    })
}

/// `op(a) · op(b)` summed in f64, the reference for the planned kernels.
fn naive(a: &Tensor<f64>, at: bool, b: &Tensor<f64>, bt: bool) -> (Vec<f64>, usize, usize) {
    let (ad, bd) = (a.dims(), b.dims());
    let (m, k) = if at { (ad[1], ad[0]) } else { (ad[0], ad[1]) };
    let n = if bt { bd[0] } else { bd[1] };
    let ael = |i: usize, p: usize| {
        if at {
            a.data()[p * m + i]
        } else {
            a.data()[i * k + p]
        }
    };
    let bel = |p: usize, j: usize| {
        if bt {
            b.data()[j * k + p]
        } else {
            b.data()[p * n + j]
        }
    };
    let mut out = vec![0.0; m * n];
    for i in 0..m {
        for j in 0..n {
            out[i * n + j] = (0..k).map(|p| ael(i, p) * bel(p, j)).sum();
        }
    }
    (out, m, n)
}

#[track_caller]
fn assert_close(got: &[f64], want: &[f64], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    let scale = want.iter().fold(1.0f64, |s, w| s.max(w.abs()));
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= 1e-12 * scale,
            "{what}: element {i}: {g} vs naive {w} (scale {scale})"
        );
    }
}

/// Forward and both gradients (with a random cotangent) of `a @ b` against the naive
/// product, for shapes that take the split-k and row-block paths in every operand layout.
#[test]
fn tall_skinny_paths_match_naive_product() {
    // (m, k, n) and the plans of forward, da = dy·bᵀ and db = aᵀ·dy.
    let cases = [
        // RealNVP layer: x (rows, 16) @ W (16, 16); db has a long inner dimension.
        (
            (5000, 16, 16),
            [
                Plan::RowBlocks { rows: 1024 },
                Plan::RowBlocks { rows: 1024 },
                Plan::SplitK { chunks: 4 },
            ],
        ),
        // A ragged tall shape: block and chunk edges fall mid-way.
        (
            (4099, 3, 5),
            [
                Plan::RowBlocks { rows: 4099 },
                Plan::RowBlocks { rows: 4099 },
                Plan::SplitK { chunks: 4 },
            ],
        ),
        // Long inner dimension in the forward pass (lhs read as stored).
        (
            (4, 5000, 3),
            [
                Plan::SplitK { chunks: 4 },
                Plan::Faer,
                Plan::RowBlocks { rows: 5000 },
            ],
        ),
        // Long inner dimension of da = dy · bᵀ (rhs read transposed).
        (
            (8, 6, 9000),
            [Plan::Faer, Plan::SplitK { chunks: 8 }, Plan::Faer],
        ),
    ];
    for ((m, k, n), plans) in cases {
        assert_eq!(
            [plan(m, n, k), plan(m, k, n), plan(k, n, m)],
            plans,
            "plans of {m}×{k}@{k}×{n}"
        );
        let (a, b, dy) = (pseudo([m, k], 1), pseudo([k, n], 2), pseudo([m, n], 3));
        let mut t = Tape::<f64>::new();
        let (av, bv) = (t.leaf(a.clone()), t.leaf(b.clone()));
        let y = t.matmul(av, bv);
        assert_close(t.value(y).data(), &naive(&a, false, &b, false).0, "forward");
        t.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
        assert_close(
            t.grad(av).unwrap().data(),
            &naive(&dy, false, &b, true).0,
            "da",
        );
        assert_close(
            t.grad(bv).unwrap().data(),
            &naive(&a, true, &dy, false).0,
            "db",
        );
    }
}

#[test]
fn tall_skinny_gradient() {
    // 4100 rows: the forward takes the row-block path, db the split-k path.
    let (x, w) = (pseudo([4100, 2], 4), pseudo([2, 3], 5));
    assert_eq!(plan(4100, 3, 2), Plan::RowBlocks { rows: 4100 });
    assert_eq!(plan(2, 3, 4100), Plan::SplitK { chunks: 4 });
    check_gradients(
        |t, v| t.matmul(v[0], v[1]),
        &[x, w],
        &CheckConfig::default(),
    )
    .unwrap();
}

#[test]
fn split_k_accumulates_into_existing_gradient() {
    // The weight used twice: the second backward adds into the first one's gradient.
    let (x, w) = (pseudo([6000, 4], 6), pseudo([4, 4], 7));
    let mut t = Tape::<f64>::new();
    let (xv, wv) = (t.constant(x.clone()), t.leaf(w));
    let y1 = t.matmul(xv, wv);
    let y2 = t.matmul(xv, wv);
    let y = t.add(y1, y2);
    let dy = pseudo([6000, 4], 8);
    t.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
    let once = naive(&x, true, &dy, false).0;
    let twice: Vec<f64> = once.iter().map(|v| 2.0 * v).collect();
    assert_close(t.grad(wv).unwrap().data(), &twice, "db twice");
}

#[test]
#[should_panic(expected = "matmul: lhs (2, 3) and rhs (4, 5) do not form (m, k) @ (k, n)")]
fn inner_mismatch_names_shapes() {
    let mut t = Tape::<f32>::new();
    let a = t.constant(Tensor::zeros([2, 3]));
    let b = t.constant(Tensor::zeros([4, 5]));
    t.matmul(a, b);
}
