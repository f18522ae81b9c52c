//! Tests of [`super`]: gradient checks, values, edge handling, and the fused kernels against a
//! naive per-sample reference in f64 and f32.

use super::*;
use crate::check::{check_gradients, strategies, CheckConfig};
use proptest::prelude::*;

/// A grid coordinate in `[−lim, lim]` whose pixel position `(v + 1)/2·(n − 1)` is at least
/// `margin` pixels away from every integer (the kinks of bilinear interpolation).
fn coord(n: usize, lim: f64, margin: f64) -> impl Strategy<Value = f64> {
    (-lim..lim).prop_map(move |v| {
        let s = (n as f64 - 1.0) / 2.0;
        if s == 0.0 {
            return v;
        }
        let p = (v + 1.0) * s;
        let frac = p - p.floor();
        let p = if frac < margin {
            p.floor() + margin
        } else if frac > 1.0 - margin {
            p.floor() + 1.0 - margin
        } else {
            p
        };
        p / s - 1.0
    })
}

fn grid_for(
    b: usize,
    ho: usize,
    wo: usize,
    h: usize,
    w: usize,
    lim: f64,
) -> impl Strategy<Value = Tensor<f64>> {
    proptest::collection::vec((coord(w, lim, 0.02), coord(h, lim, 0.02)), b * ho * wo).prop_map(
        move |v| {
            Tensor::from_fn([b, ho, wo, 2], |i| {
                if i % 2 == 0 {
                    v[i / 2].0
                } else {
                    v[i / 2].1
                }
            })
        },
    )
}

/// Image `(B, C, H, W)` and a grid reaching past the border (`|x|, |y| ≤ 1.3`), so samples
/// fall inside, on the fading last pixel outside, and fully outside.
fn case() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>)> {
    (
        1usize..=2,
        1usize..=3,
        1usize..=5,
        1usize..=5,
        1usize..=4,
        1usize..=4,
    )
        .prop_flat_map(|(b, c, h, w, ho, wo)| {
            (
                strategies::tensor_of(vec![b, c, h, w]),
                grid_for(b, ho, wo, h, w, 1.3),
            )
        })
}

proptest! {
    #![proptest_config(strategies::config())]

    #[test]
    fn grid_sample_gradient((img, grid) in case()) {
        check_gradients(|t, v| t.grid_sample(v[0], v[1]), &[img, grid], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    /// Samples hugging the border from both sides: pixel positions in `(−1, 0)` and
    /// `(W − 1, W)`, where only one column (row) of taps is inside.
    #[test]
    fn grid_sample_gradient_at_the_edge(
        (img, grid) in (1usize..=2, 2usize..=5, 2usize..=5).prop_flat_map(|(c, h, w)| (
            strategies::tensor_of(vec![1, c, h, w]),
            proptest::collection::vec((0.02f64..0.98, any::<bool>(), 0.02f64..0.98, any::<bool>()), 6)
                .prop_map(move |v| {
                    let edge = |f: f64, hi: bool, n: usize| {
                        let p = if hi { n as f64 - 1.0 + f } else { -f };
                        p / ((n as f64 - 1.0) / 2.0) - 1.0
                    };
                    Tensor::from_fn([1, 2, 3, 2], |i| {
                        let (fx, hx, fy, hy) = v[i / 2];
                        if i % 2 == 0 { edge(fx, hx, w) } else { edge(fy, hy, h) }
                    })
                }),
        ))
    ) {
        check_gradients(|t, v| t.grid_sample(v[0], v[1]), &[img, grid], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }
}

#[test]
fn identity_grid_reproduces_the_image_and_corners_are_pixel_centres() {
    let (h, w) = (4, 5);
    let img = Tensor::from_fn([2, 3, h, w], |i| (i as f64 * 0.61).sin());
    let grid = Tensor::from_fn([2, h, w, 2], |i| {
        let p = (i / 2) % (h * w);
        let (y, x) = (p / w, p % w);
        if i % 2 == 0 {
            2.0 * x as f64 / (w - 1) as f64 - 1.0
        } else {
            2.0 * y as f64 / (h - 1) as f64 - 1.0
        }
    });
    let mut tape = Tape::<f64>::new();
    let (vi, vg) = (tape.constant(img.clone()), tape.constant(grid));
    let out = tape.grid_sample(vi, vg);
    assert!(tape.value(out).max_abs_diff(&img) < 1e-12);
}

#[test]
fn bilinear_value_and_zero_padding() {
    // 2×2 image [[1, 2], [3, 4]]: the centre is the mean; half a pixel outside column 0 is
    // half of the left column blend; far outside is 0.
    let img = Tensor::from_vec([1, 1, 2, 2], vec![1.0, 2.0, 3.0, 4.0]);
    let grid = Tensor::from_vec([1, 1, 3, 2], vec![0.0, 0.0, -2.0, -1.0, 5.0, 0.0]);
    let mut tape = Tape::<f64>::new();
    let (vi, vg) = (tape.constant(img), tape.constant(grid));
    let out = tape.grid_sample(vi, vg);
    // x = −2 → px = −0.5: half of column 0 at row 0 (value 1).
    assert_eq!(tape.value(out).data(), &[2.5, 0.5, 0.0]);
}

#[test]
fn mask_uses_nearest_pixel() {
    // Width 5: px = (x + 1)·2. Inside iff round(px) ∈ [0, 4].
    let xs = [-1.24, -1.26, 1.24, 1.26, 0.0];
    let grid = Tensor::from_fn([1, 1, 5, 2], |i| if i % 2 == 0 { xs[i / 2] } else { 0.0 });
    let m = grid_sample_mask(&grid, 3, 5);
    assert_eq!(m.dims(), &[1, 1, 1, 5]);
    assert_eq!(m.data(), &[1.0, 0.0, 1.0, 0.0, 1.0]);
}

#[test]
fn a_tape_recording_the_mask_every_step_holds_the_same_pool_after_each_clear() {
    // A step that warps and masks, as the cortex's P does: the tape's idle buffers after each
    // clear must not grow with the steps (the mask was once made outside the pool, and every
    // clear added its buffer to it).
    let mut tape = Tape::<f32>::new();
    let mut idle = Vec::new();
    for step in 0..5 {
        tape.clear();
        let shift = 0.1 * step as f64;
        let grid = Tensor::from_fn([2, 6, 6, 2], |i| ((i as f64 * 0.37 + shift).sin()) as f32);
        let img = tape.constant_from([2, 1, 6, 6], &[0.5f32; 72]);
        let g = tape.constant_from([2, 6, 6, 2], grid.data());
        let warped = tape.grid_sample(img, g);
        let mask = tape.grid_sample_mask(g, 6, 6);
        let masked = tape.mul(warped, mask);
        let m = grid_sample_mask(tape.value(g), 6, 6);
        assert_eq!(tape.value(mask).data(), m.data(), "step {step}");
        let _ = tape.sum(masked);
        tape.clear();
        idle.push(tape.pool().free_bytes());
    }
    assert!(
        idle.windows(2).all(|w| w[0] == w[1]),
        "idle bytes by step: {idle:?}"
    );
}

#[test]
#[should_panic(
    expected = "grid_sample: expected a grid (B, Ho, Wo, 2) with B = 2 for the image (2, 1, 4, 4), got (3, 4, 4, 2)"
)]
fn batch_mismatch_panics_with_both_shapes() {
    let mut tape = Tape::<f32>::new();
    let img = tape.constant(Tensor::zeros([2, 1, 4, 4]));
    let grid = tape.constant(Tensor::zeros([3, 4, 4, 2]));
    tape.grid_sample(img, grid);
}

/// Naive per-output-element reference of the forward value and both gradients for a cotangent
/// `dy`: the formulas of the module docs, four corners with explicit inside checks, `floor`
/// from `num_traits`. Returns `(out, ∂L/∂img, ∂L/∂grid)`.
fn reference<T: Float>(img: &Tensor<T>, grid: &Tensor<T>, dy: &Tensor<T>) -> [Vec<T>; 3] {
    let (b, c, h, w, ho, wo) = dims(img.shape(), grid.shape());
    let (sx, sy) = (T::of((w as f64 - 1.0) / 2.0), T::of((h as f64 - 1.0) / 2.0));
    let mut out = vec![T::zero(); b * c * ho * wo];
    let mut gi = vec![T::zero(); img.numel()];
    let mut gg = vec![T::zero(); grid.numel()];
    let one = T::one();
    for n in 0..b {
        for p in 0..ho * wo {
            let g = &grid.data()[2 * (n * ho * wo + p)..][..2];
            let (px, py) = ((g[0] + one) * sx, (g[1] + one) * sy);
            let (x0, y0) = (px.floor(), py.floor());
            let (fx, fy) = (px - x0, py - y0);
            for ch in 0..c {
                let o = (n * c + ch) * ho * wo + p;
                let d = dy.data()[o];
                for (ax, ay) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (cx, cy) = (x0.as_f64() + ax as f64, y0.as_f64() + ay as f64);
                    if cx < 0.0 || cy < 0.0 || cx > (w - 1) as f64 || cy > (h - 1) as f64 {
                        continue;
                    }
                    let i = (n * c + ch) * h * w + cy as usize * w + cx as usize;
                    let v = img.data()[i];
                    let (wx, sgx) = if ax == 1 { (fx, one) } else { (one - fx, -one) };
                    let (wy, sgy) = if ay == 1 { (fy, one) } else { (one - fy, -one) };
                    out[o] += wx * wy * v;
                    gi[i] += wx * wy * d;
                    gg[2 * (n * ho * wo + p)] += d * sgx * wy * v * sx;
                    gg[2 * (n * ho * wo + p) + 1] += d * sgy * wx * v * sy;
                }
            }
        }
    }
    [out, gi, gg]
}

/// The op's value and gradients (through the tape, seeded with `dy`) against [`reference`].
fn matches_reference<T: Float>(img: Tensor<T>, grid: Tensor<T>, dy: Tensor<T>, tol: f64) {
    let want = reference(&img, &grid, &dy);
    let mut tape = Tape::<T>::new();
    let (vi, vg) = (tape.leaf(img), tape.leaf(grid));
    let y = tape.grid_sample(vi, vg);
    tape.backward_from(&[(y, dy)], &mut crate::NoHooks);
    let got = [
        tape.value(y).data(),
        tape.grad(vi).unwrap().data(),
        tape.grad(vg).unwrap().data(),
    ];
    for (what, (got, want)) in ["value", "image gradient", "grid gradient"]
        .iter()
        .zip(got.iter().zip(&want))
    {
        assert_eq!(got.len(), want.len());
        for (k, (g, e)) in got.iter().zip(want).enumerate() {
            let (g, e) = (g.as_f64(), e.as_f64());
            assert!(
                (g - e).abs() <= tol * (1.0 + e.abs()),
                "{what}[{k}]: kernel {g} vs reference {e}"
            );
        }
    }
}

/// A grid for an `h × w` image mixing interior points, points hugging the border from both
/// sides, exact pixel centres on the border (`±1`), and points far outside.
fn edge_grid(b: usize, ho: usize, wo: usize, seed: f64) -> Tensor<f64> {
    let special = [
        -1.0,
        1.0,
        -1.0 - 1e-7,
        1.0 + 1e-7,
        -1.6,
        1.6,
        -40.0,
        40.0,
        0.0,
    ];
    Tensor::from_fn([b, ho, wo, 2], |i| {
        let r = ((i as f64 + seed) * 0.7548776662).fract();
        if i % 5 == 3 {
            special[(i / 5) % special.len()]
        } else {
            2.6 * r - 1.3
        }
    })
}

fn reference_case(
    b: usize,
    c: usize,
    h: usize,
    w: usize,
    ho: usize,
    wo: usize,
) -> [Tensor<f64>; 3] {
    [
        Tensor::from_fn([b, c, h, w], |i| ((i as f64) * 0.913).sin()),
        edge_grid(b, ho, wo, (h * 7 + w) as f64),
        Tensor::from_fn([b, c, ho, wo], |i| ((i as f64) * 1.37 + 0.4).cos()),
    ]
}

const REFERENCE_SHAPES: [(usize, usize, usize, usize, usize, usize); 5] = [
    (2, 3, 5, 7, 4, 6),
    (1, 1, 1, 1, 3, 3),
    (3, 2, 1, 6, 2, 5),
    (2, 4, 9, 9, 9, 9),
    (1, 2, 16, 12, 5, 11),
];

#[test]
fn fused_kernels_match_reference_f64() {
    for (b, c, h, w, ho, wo) in REFERENCE_SHAPES {
        let [img, grid, dy] = reference_case(b, c, h, w, ho, wo);
        matches_reference(img, grid, dy, 1e-12);
    }
}

#[test]
fn fused_kernels_match_reference_f32() {
    for (b, c, h, w, ho, wo) in REFERENCE_SHAPES {
        let [img, grid, dy] = reference_case(b, c, h, w, ho, wo);
        matches_reference(img.cast::<f32>(), grid.cast(), dy.cast(), 2e-5);
    }
}

/// Only one of the two inputs wanting a gradient takes the other kernel variants.
#[test]
fn one_sided_gradients_match_reference() {
    let [img, grid, dy] = reference_case(2, 3, 6, 5, 4, 4);
    let [_, want_gi, want_gg] = reference(&img, &grid, &dy);
    for img_is_leaf in [true, false] {
        let mut tape = Tape::<f64>::new();
        let (vi, vg) = if img_is_leaf {
            (tape.leaf(img.clone()), tape.constant(grid.clone()))
        } else {
            (tape.constant(img.clone()), tape.leaf(grid.clone()))
        };
        let y = tape.grid_sample(vi, vg);
        tape.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
        let (v, want) = if img_is_leaf {
            (vi, &want_gi)
        } else {
            (vg, &want_gg)
        };
        let got = tape.grad(v).unwrap().data();
        for (g, e) in got.iter().zip(want) {
            assert!((g - e).abs() < 1e-12 * (1.0 + e.abs()), "{g} vs {e}");
        }
    }
}

#[test]
fn non_finite_and_empty_cases() {
    // Infinite and NaN coordinates: infinities are outside (0); NaN propagates as in PyTorch.
    let img = Tensor::from_vec([1, 1, 2, 2], vec![1.0f32, 2.0, 3.0, 4.0]);
    let grid = Tensor::from_vec(
        [1, 1, 2, 2],
        vec![f32::INFINITY, 0.0, f32::NEG_INFINITY, 0.0],
    );
    let mut tape = Tape::<f32>::new();
    let (vi, vg) = (tape.constant(img), tape.constant(grid));
    let y = tape.grid_sample(vi, vg);
    assert_eq!(tape.value(y).data(), &[0.0, 0.0]);
    // An empty image: every sample is outside.
    let img = tape.constant(Tensor::<f32>::zeros([1, 2, 0, 3]));
    let grid = tape.constant(Tensor::full([1, 2, 2, 2], 0.5f32));
    let y = tape.grid_sample(img, grid);
    assert_eq!(tape.value(y).data(), &[0.0; 8]);
}
