//! Tests of `conv2d` and `conv_transpose2x2`: gradient checks over proptest shapes (tiny images
//! so reflect borders dominate), a direct-loop reference on images big enough to be tiled, a
//! hand-computed reflect example, and shape panics.

use super::*;
use crate::check::{check_gradients, strategies as st, CheckConfig};
use proptest::prelude::*;
use std::sync::atomic::Ordering;

/// Direct convolution with an explicitly built padded image (independent of `lowering`).
fn naive_conv(x: &Tensor<f64>, w: &Tensor<f64>, mode: Padding) -> Tensor<f64> {
    let (bn, c, h, wd) = x.shape().bchw("ref");
    let (co, _, k, _) = w.shape().bchw("ref");
    let p = (k / 2) as isize;
    let pick = |i: isize, n: usize| -> Option<usize> {
        let n = n as isize;
        match mode {
            _ if i >= 0 && i < n => Some(i as usize),
            Padding::Zero => None,
            Padding::Reflect if i < 0 => Some((-i) as usize),
            Padding::Reflect => Some((2 * n - 2 - i) as usize),
        }
    };
    Tensor::from_fn([bn, co, h, wd], |f| {
        let (b, o, i, j) = (f / (co * h * wd), (f / (h * wd)) % co, (f / wd) % h, f % wd);
        let mut s = 0.0;
        for ci in 0..c {
            for a in 0..k {
                for bb in 0..k {
                    let (r, q) = (
                        pick(i as isize + a as isize - p, h),
                        pick(j as isize + bb as isize - p, wd),
                    );
                    if let (Some(r), Some(q)) = (r, q) {
                        s += w.data()[((o * c + ci) * k + a) * k + bb]
                            * x.data()[((b * c + ci) * h + r) * wd + q];
                    }
                }
            }
        }
        s
    })
}

fn lcg_tensor(shape: &[usize], seed: u64) -> Tensor<f64> {
    let mut s = seed;
    Tensor::from_fn(shape, |_| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    })
}

/// (x, w, padding) with tiny images; reflect needs (k−1)/2 < H, W.
fn conv_case() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>, Padding)> {
    (
        1usize..=2,
        1usize..=3,
        1usize..=3,
        2usize..=6,
        2usize..=6,
        prop_oneof![Just(1usize), Just(3)],
        any::<bool>(),
    )
        .prop_flat_map(|(b, ci, co, h, w, k, reflect)| {
            let k = if k == 3 && h > 2 && w > 2 && reflect && (h + w) % 3 == 0 {
                5
            } else {
                k
            };
            let mode = if reflect {
                Padding::Reflect
            } else {
                Padding::Zero
            };
            (
                st::tensor_of(vec![b, ci, h, w]),
                st::tensor_of(vec![co, ci, k, k]),
                Just(mode),
            )
        })
}

/// `relu(naive_conv)` and its input/weight gradients for the cotangent `r`.
fn naive_conv_relu_grads(
    x: &Tensor<f64>,
    w: &Tensor<f64>,
    r: &Tensor<f64>,
    mode: Padding,
) -> (Tensor<f64>, Tensor<f64>, Tensor<f64>) {
    let y = naive_conv(x, w, mode);
    let masked = Tensor::from_fn(
        r.shape(),
        |i| if y.data()[i] > 0.0 { r.data()[i] } else { 0.0 },
    );
    let (gx, gw) = naive_conv_grads(x, w, &masked, mode);
    (Tensor::from_fn(y.shape(), |i| y.data()[i].max(0.0)), gx, gw)
}

proptest! {
    #![proptest_config(st::config())]

    #[test]
    fn conv2d_relu_gradients((x, w, mode) in conv_case()) {
        // Skip draws with an output within 1e-3 of the ReLU kink (finite differences straddle it).
        let y = naive_conv(&x, &w, mode);
        prop_assume!(y.data().iter().all(|v| v.abs() > 1e-3));
        let r = check_gradients(|t, v| t.conv2d_relu(v[0], v[1], mode), &[x.clone(), w.clone()], &CheckConfig::default());
        prop_assert!(r.is_ok(), "conv2d_relu {mode:?} x {:?} w {:?}: {}", x.shape(), w.shape(), r.unwrap_err());
    }

    #[test]
    fn conv2d_gradients((x, w, mode) in conv_case()) {
        let r = check_gradients(|t, v| t.conv2d(v[0], v[1], mode), &[x.clone(), w.clone()], &CheckConfig::default());
        prop_assert!(r.is_ok(), "conv2d {mode:?} x {:?} w {:?}: {}", x.shape(), w.shape(), r.unwrap_err());
    }

    /// `x` and `w` feed two convs: the later conv's backward gets fresh gradient buffers
    /// (overwritten; NaN-filled under test, so a missed element fails), the earlier one adds.
    #[test]
    fn conv2d_gradients_into_shared_inputs((x, w, mode) in conv_case()) {
        let r = check_gradients(
            |t, v| {
                let a = t.conv2d(v[0], v[1], mode);
                let b = t.conv2d(v[0], v[1], Padding::Zero);
                t.add(a, b)
            },
            &[x.clone(), w.clone()],
            &CheckConfig::default(),
        );
        prop_assert!(r.is_ok(), "conv2d twice {mode:?} x {:?} w {:?}: {}", x.shape(), w.shape(), r.unwrap_err());
    }

    #[test]
    fn conv2d_matches_direct_loops((x, w, mode) in conv_case()) {
        let mut t = Tape::<f64>::new();
        let (xv, wv) = (t.constant(x.clone()), t.constant(w.clone()));
        let y = t.conv2d(xv, wv, mode);
        prop_assert!(t.value(y).max_abs_diff(&naive_conv(&x, &w, mode)) < 1e-12);
    }

    #[test]
    fn conv_transpose_gradients(
        x in (1usize..=2, 1usize..=3, 1usize..=4, 1usize..=4).prop_flat_map(|(b, c, h, w)| st::tensor_of(vec![b, c, h, w])),
        co in 1usize..=3,
        seed in any::<u64>(),
    ) {
        let w = lcg_tensor(&[x.dims()[1], co, 2, 2], seed);
        let r = check_gradients(|t, v| t.conv_transpose2x2(v[0], v[1]), &[x.clone(), w], &CheckConfig::default());
        prop_assert!(r.is_ok(), "conv_transpose2x2 x {:?}: {}", x.shape(), r.unwrap_err());
    }
}

#[test]
fn reflect_example_by_hand() {
    // x = [[1 2 3], [4 5 6]], reflect-padded, summed by a 3×3 box (worked out on paper).
    let mut t = Tape::<f64>::new();
    let x = t.constant(Tensor::from_vec([1, 1, 2, 3], vec![1., 2., 3., 4., 5., 6.]));
    let w = t.constant(Tensor::full([1, 1, 3, 3], 1.0));
    let y = t.conv2d(x, w, Padding::Reflect);
    assert_eq!(t.value(y).data(), &[33., 36., 39., 24., 27., 30.]);
    let y = t.conv2d(x, w, Padding::Zero);
    assert_eq!(t.value(y).data(), &[12., 21., 16., 12., 21., 16.]);
}

/// Direct-loop backward of `Σ r ⊙ conv(x, w)`: ∂x and ∂w by scattering each product.
fn naive_conv_grads(
    x: &Tensor<f64>,
    w: &Tensor<f64>,
    r: &Tensor<f64>,
    mode: Padding,
) -> (Tensor<f64>, Tensor<f64>) {
    let (bn, c, h, wd) = x.shape().bchw("ref");
    let (co, _, k, _) = w.shape().bchw("ref");
    let p = (k / 2) as isize;
    let pick = |i: isize, n: usize| -> Option<usize> {
        let n = n as isize;
        if (0..n).contains(&i) {
            Some(i as usize)
        } else if mode == Padding::Zero {
            None
        } else if i < 0 {
            Some((-i) as usize)
        } else {
            Some((2 * n - 2 - i) as usize)
        }
    };
    let (mut gx, mut gw) = (Tensor::zeros(x.shape()), Tensor::zeros(w.shape()));
    for b in 0..bn {
        for o in 0..co {
            for i in 0..h {
                for j in 0..wd {
                    let d = r.data()[((b * co + o) * h + i) * wd + j];
                    for ci in 0..c {
                        for a in 0..k {
                            for bb in 0..k {
                                if let (Some(y), Some(z)) = (
                                    pick(i as isize + a as isize - p, h),
                                    pick(j as isize + bb as isize - p, wd),
                                ) {
                                    let (xi, wi) = (
                                        ((b * c + ci) * h + y) * wd + z,
                                        ((o * c + ci) * k + a) * k + bb,
                                    );
                                    gx.data_mut()[xi] += d * w.data()[wi];
                                    gw.data_mut()[wi] += d * x.data()[xi];
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    (gx, gw)
}

#[test]
fn tiled_large_image_matches_direct_loops() {
    // 300×150 with 8 input and 3 output channels is cut into several row tiles per image, in
    // forward and in both halves of backward.
    assert!(
        lowering::tiles(300, 152 * (8 + 3)).len() >= 3
            && lowering::tiles(302, 154 * (8 + 3)).len() >= 3,
        "test must exercise several tiles"
    );
    for (mode, batch) in [(Padding::Reflect, 1), (Padding::Zero, 2)] {
        let x = lcg_tensor(&[batch, 8, 300, 150], 1);
        let w = lcg_tensor(&[3, 8, 3, 3], 2);
        let r = lcg_tensor(&[batch, 3, 300, 150], 3);
        let mut t = Tape::<f64>::new();
        let (xv, wv) = (t.leaf(x.clone()), t.leaf(w.clone()));
        let y = t.conv2d(xv, wv, mode);
        assert!(t.value(y).max_abs_diff(&naive_conv(&x, &w, mode)) < 1e-12);
        t.backward_from(&[(y, r.clone())], &mut crate::NoHooks);
        let (gx, gw) = naive_conv_grads(&x, &w, &r, mode);
        assert!(t.grad(xv).unwrap().max_abs_diff(&gx) < 1e-10, "{mode:?} dx");
        assert!(t.grad(wv).unwrap().max_abs_diff(&gw) < 1e-9, "{mode:?} dw");
    }
}

#[test]
fn conv_transpose_places_each_tap() {
    // One input pixel, one channel: the 2×2 output block is the kernel itself.
    let mut t = Tape::<f64>::new();
    let x = t.constant(Tensor::from_vec([1, 1, 1, 2], vec![2.0, -1.0]));
    let w = t.constant(Tensor::from_vec([1, 1, 2, 2], vec![1., 2., 3., 4.]));
    let y = t.conv_transpose2x2(x, w);
    assert_eq!(t.shape(y), Shape::new(&[1, 1, 2, 4]));
    assert_eq!(t.value(y).data(), &[2., 4., -1., -2., 6., 8., -3., -4.]);
}

#[test]
#[should_panic(expected = "conv2d: input (1, 2, 4, 4) and weight (3, 5, 3, 3) do not fit")]
fn conv2d_channel_mismatch_panics() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([1, 2, 4, 4]));
    let w = t.constant(Tensor::zeros([3, 5, 3, 3]));
    t.conv2d(x, w, Padding::Zero);
}

#[test]
#[should_panic(
    expected = "conv2d: reflect padding 1 needs an image larger than that, input (1, 1, 1, 4)"
)]
fn conv2d_reflect_on_one_row_panics() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([1, 1, 1, 4]));
    let w = t.constant(Tensor::zeros([1, 1, 3, 3]));
    t.conv2d(x, w, Padding::Reflect);
}

#[test]
#[should_panic(
    expected = "conv_transpose2x2: input (1, 3, 2, 2) and weight (2, 4, 2, 2) do not fit"
)]
fn conv_transpose_mismatch_panics() {
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([1, 3, 2, 2]));
    let w = t.constant(Tensor::zeros([2, 4, 2, 2]));
    t.conv_transpose2x2(x, w);
}

#[test]
fn f32_matches_f64() {
    let x = lcg_tensor(&[2, 5, 9, 11], 4);
    let w = lcg_tensor(&[6, 5, 3, 3], 5);
    let want = naive_conv(&x, &w, Padding::Reflect);
    let mut t = Tape::<f32>::new();
    let (xv, wv) = (t.constant(x.cast()), t.constant(w.cast()));
    let y = t.conv2d(xv, wv, Padding::Reflect);
    assert!(t.value(y).cast::<f64>().max_abs_diff(&want) < 1e-5);
}

#[test]
fn conv2d_relu_matches_direct_loops() {
    // Values, ∂x and ∂w of the fused op against relu(direct conv), zero and reflect, 3×3 and
    // 1×1, on images large enough to be tiled.
    for (mode, batch, k, h, wd) in [
        (Padding::Reflect, 2, 3, 150, 37),
        (Padding::Zero, 3, 3, 20, 9),
        (Padding::Reflect, 2, 5, 11, 8),
        (Padding::Zero, 2, 1, 7, 5),
    ] {
        let x = lcg_tensor(&[batch, 6, h, wd], 11);
        let w = lcg_tensor(&[4, 6, k, k], 12);
        let r = lcg_tensor(&[batch, 4, h, wd], 13);
        let mut t = Tape::<f64>::new();
        let (xv, wv) = (t.leaf(x.clone()), t.leaf(w.clone()));
        let y = t.conv2d_relu(xv, wv, mode);
        let (want, gx, gw) = naive_conv_relu_grads(&x, &w, &r, mode);
        assert!(want.data().contains(&0.0) && want.data().iter().any(|&v| v > 0.0));
        assert!(
            t.value(y).max_abs_diff(&want) < 1e-12,
            "{mode:?} k{k} value"
        );
        t.backward_from(&[(y, r)], &mut crate::NoHooks);
        assert!(
            t.grad(xv).unwrap().max_abs_diff(&gx) < 1e-10,
            "{mode:?} k{k} dx"
        );
        assert!(
            t.grad(wv).unwrap().max_abs_diff(&gw) < 1e-9,
            "{mode:?} k{k} dw"
        );
    }
}

#[test]
fn output_buffers_are_not_assumed_zero() {
    // The tape hands conv a recycled buffer without zeroing it (`overwrites_output`): run a
    // different computation first so the pooled buffers hold garbage, then compare.
    let x = lcg_tensor(&[2, 3, 8, 8], 21);
    let w = lcg_tensor(&[3, 3, 3, 3], 22);
    let want = naive_conv(&x, &w, Padding::Reflect);
    let mut t = Tape::<f64>::new();
    let junk = t.constant(Tensor::full([2, 3, 8, 8], 7.0));
    let _ = t.relu(junk);
    t.clear();
    let (xv, wv) = (t.constant(x.clone()), t.constant(w.clone()));
    let y = t.conv2d(xv, wv, Padding::Reflect);
    assert!(t.value(y).max_abs_diff(&want) < 1e-12);
}

mod direct_kernels;
