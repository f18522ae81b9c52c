//! Tests of the reductions: gradients, axis shapes and values, f64 accumulation, and sums that do not depend on the thread count.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use proptest::prelude::*;

fn with_axes() -> impl Strategy<Value = (Tensor<f64>, Vec<usize>, bool)> {
    (1usize..=4).prop_flat_map(|r| {
        (
            st::tensor(r),
            proptest::collection::vec(any::<bool>(), r),
            any::<bool>(),
        )
            .prop_map(|(x, pick, keep)| {
                let axes = (0..pick.len()).filter(|&a| pick[a]).collect();
                (x, axes, keep)
            })
    })
}

proptest! {
    #![proptest_config(st::config())]

    #[test]
    fn whole_reductions(x in (1usize..=3).prop_flat_map(st::tensor)) {
        for name in ["sum", "mean", "max", "min"] {
            let r = check_gradients(|t, v| {
                // Square first so the check sees a non-constant gradient.
                let s = t.square(v[0]);
                match name { "sum" => t.sum(s), "mean" => t.mean(s), "max" => t.max(v[0]), _ => t.min(v[0]) }
            }, std::slice::from_ref(&x), &CheckConfig::default());
            prop_assert!(r.is_ok(), "{name}: {}", r.unwrap_err());
        }
    }

    #[test]
    fn axis_reductions((x, axes, keepdim) in with_axes()) {
        let r = check_gradients(|t, v| t.sum_axes(v[0], &axes, keepdim), std::slice::from_ref(&x), &CheckConfig::default());
        prop_assert!(r.is_ok(), "sum_axes {axes:?}: {}", r.unwrap_err());
        let r = check_gradients(|t, v| t.mean_axes(v[0], &axes, keepdim), &[x], &CheckConfig::default());
        prop_assert!(r.is_ok(), "mean_axes {axes:?}: {}", r.unwrap_err());
    }
}

#[test]
fn axis_shapes_and_values() {
    let mut t = Tape::<f64>::new();
    let x = t.constant(Tensor::from_fn([2, 3, 4], |i| i as f64));
    let a = t.sum_axes(x, &[1], false);
    assert_eq!(t.shape(a), Shape::new(&[2, 4]));
    // x[0, :, 0] = 0, 4, 8
    assert_eq!(t.value(a).data()[0], 12.0);
    let b = t.mean_axes(x, &[0, 2], true);
    assert_eq!(t.shape(b), Shape::new(&[1, 3, 1]));
    // mean over x[:, 1, :] = {4..8} ∪ {16..20}
    assert_eq!(
        t.value(b).data()[1],
        (4 + 5 + 6 + 7 + 16 + 17 + 18 + 19) as f64 / 8.0
    );
    let all = t.sum_axes(x, &[0, 1, 2], false);
    assert_eq!(t.shape(all), Shape::scalar());
    assert_eq!(t.value(all).item(), (0..24).sum::<i32>() as f64);
}

#[test]
fn f32_sum_accumulates_in_f64() {
    let n = 1 << 22;
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::full([n], 0.1f32));
    let s = t.sum(x);
    let want = n as f64 * 0.1f32 as f64;
    assert!((t.value(s).item() as f64 - want).abs() < 1e-6 * want);
}

/// `f()` on a rayon pool of `threads` threads: for tests that results do not depend on
/// the thread count.
pub(crate) fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build();
    pool.expect("a rayon pool").install(f)
}

/// Past one task (`TASK_ELEMS`), the sum runs in parallel: the same bits with 1 thread
/// as with 3, equal to an exact integer sum, and the backward fill covers every element
/// (fresh) and adds (accumulating).
#[test]
fn large_sums_are_exact_deterministic_and_fill_every_gradient() {
    let n = 3 * TASK_ELEMS + 5;
    let run = |threads: usize| {
        on_threads(threads, || {
            let mut t = Tape::<f32>::new();
            let x = t.leaf(Tensor::from_fn([n], |i| (i % 1000) as f32 - 499.75));
            let (s, m) = (t.sum(x), t.mean(x));
            let l = t.add(s, m);
            t.backward(l);
            let g = t.grad(x).unwrap().data().to_vec();
            (t.value(s).item(), g)
        })
    };
    let (one, g1) = run(1);
    let (three, g3) = run(3);
    assert_eq!(one.to_bits(), three.to_bits());
    let exact: f64 = (0..n).map(|i| (i % 1000) as f64 - 499.75).sum();
    assert_eq!(one as f64, exact as f32 as f64);
    let want = 1.0 + 1.0 / n as f32;
    assert!(g1.iter().all(|&g| g == want), "∂(sum + mean)/∂x ≠ 1 + 1/n");
    assert_eq!(g1, g3);
}

#[test]
#[should_panic(expected = "sum_axes: axis 2 out of range for (2, 3)")]
fn bad_axis_panics() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([2, 3]));
    t.sum_axes(x, &[2], false);
}
