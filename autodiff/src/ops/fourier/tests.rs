//! Tests of the Fourier-domain ops: transforms against a naive DFT and the gradient of every op.

use super::*;
use crate::check::{check_gradients, check_inputs, strategies, CheckConfig};
use proptest::prelude::*;
use std::f64::consts::PI;

/// Naive `O((HW)²)` DFT of one complex image, sign `−` (forward) or `+` (inverse).
fn naive_dft(x: &[f64], h: usize, w: usize, sign: f64) -> Vec<f64> {
    let mut out = vec![0.0; 2 * h * w];
    for k in 0..h {
        for l in 0..w {
            let (mut re, mut im) = (0.0, 0.0);
            for y in 0..h {
                for xx in 0..w {
                    let phase =
                        sign * 2.0 * PI * ((k * y) as f64 / h as f64 + (l * xx) as f64 / w as f64);
                    let (s, c) = phase.sin_cos();
                    let (a, b) = (x[2 * (y * w + xx)], x[2 * (y * w + xx) + 1]);
                    re += a * c - b * s;
                    im += a * s + b * c;
                }
            }
            out[2 * (k * w + l)] = re;
            out[2 * (k * w + l) + 1] = im;
        }
    }
    out
}

fn complex_tensor(batch: usize, h: usize, w: usize) -> impl Strategy<Value = Tensor<f64>> {
    strategies::tensor_of(vec![batch, h, w, 2])
}

/// `b` with every complex entry of modulus below 0.1 scaled out to 0.1 (phase kept; 0 → 0.1).
fn away_from_zero(mut b: Tensor<f64>) -> Tensor<f64> {
    for z in b.data_mut().chunks_exact_mut(2) {
        let modulus = z[0].hypot(z[1]);
        if modulus == 0.0 {
            z[0] = 0.1;
        } else if modulus < 0.1 {
            z[0] *= 0.1 / modulus;
            z[1] *= 0.1 / modulus;
        }
    }
    b
}

fn sizes() -> impl Strategy<Value = (usize, usize, usize)> {
    (1usize..=3, 1usize..=7, 1usize..=7)
}

proptest! {
    #![proptest_config(strategies::config())]

    #[test]
    fn fft2_matches_naive_dft(x in sizes().prop_flat_map(|(b, h, w)| complex_tensor(b, h, w))) {
        let (b, h, w) = complex_dims("test", x.shape());
        let mut tape = Tape::<f64>::new();
        let v = tape.constant(x.clone());
        let y = tape.fft2(v);
        let z = tape.ifft2(v);
        for i in 0..b {
            let img = &x.data()[2 * h * w * i..2 * h * w * (i + 1)];
            let want = naive_dft(img, h, w, -1.0);
            let got = &tape.value(y).data()[2 * h * w * i..2 * h * w * (i + 1)];
            for (g, e) in got.iter().zip(&want) {
                prop_assert!((g - e).abs() < 1e-9 * (1.0 + e.abs()), "fft2 {g} vs naive {e}");
            }
            let want = naive_dft(img, h, w, 1.0);
            let got = &tape.value(z).data()[2 * h * w * i..2 * h * w * (i + 1)];
            for (g, e) in got.iter().zip(&want) {
                let e = e / (h * w) as f64;
                prop_assert!((g - e).abs() < 1e-9 * (1.0 + e.abs()), "ifft2 {g} vs naive {e}");
            }
        }
    }

    #[test]
    fn ifft2_inverts_fft2(x in sizes().prop_flat_map(|(b, h, w)| complex_tensor(b, h, w))) {
        let mut tape = Tape::<f64>::new();
        let v = tape.constant(x.clone());
        let f = tape.fft2(v);
        let back = tape.ifft2(f);
        prop_assert!(tape.value(back).max_abs_diff(&x) < 1e-12);
    }

    #[test]
    fn fft2_gradient(x in sizes().prop_flat_map(|(b, h, w)| complex_tensor(b, h, w))) {
        check_gradients(|t, v| t.fft2(v[0]), &[x], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    #[test]
    fn ifft2_gradient(x in sizes().prop_flat_map(|(b, h, w)| complex_tensor(b, h, w))) {
        check_gradients(|t, v| t.ifft2(v[0]), &[x], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    /// The real-input / real-output transforms equal the complex ones around them.
    #[test]
    fn real_transforms_match_complex_ones(
        (x, spec) in sizes().prop_flat_map(|(b, h, w)| (strategies::tensor_of(vec![b, h, w]), complex_tensor(b, h, w)))
    ) {
        let mut tape = Tape::<f64>::new();
        let (vx, vs) = (tape.constant(x), tape.constant(spec));
        let a = tape.fft2_real(vx);
        let c = tape.to_complex(vx);
        let b = tape.fft2(c);
        prop_assert!(tape.value(a).max_abs_diff(tape.value(b)) < 1e-12);
        let a = tape.ifft2_real(vs);
        let c = tape.ifft2(vs);
        let b = tape.real_part(c);
        prop_assert!(tape.value(a).max_abs_diff(tape.value(b)) < 1e-12);
    }

    #[test]
    fn fft2_real_gradient(x in sizes().prop_flat_map(|(b, h, w)| strategies::tensor_of(vec![b, h, w]))) {
        check_gradients(|t, v| t.fft2_real(v[0]), &[x], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    #[test]
    fn ifft2_real_gradient(x in sizes().prop_flat_map(|(b, h, w)| complex_tensor(b, h, w))) {
        check_gradients(|t, v| t.ifft2_real(v[0]), &[x], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    #[test]
    fn to_complex_and_real_part_gradients(x in strategies::tensor(3)) {
        let cfg = CheckConfig::default();
        check_gradients(|t, v| t.to_complex(v[0]), std::slice::from_ref(&x), &cfg)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let d = x.dims().to_vec();
        let c = Tensor::from_fn([d[0], d[1], d[2], 2], |i| x.data()[i / 2] * if i % 2 == 0 { 1.0 } else { -0.5 });
        check_gradients(|t, v| t.real_part(v[0]), &[c], &cfg)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    /// `b` is either one response broadcast over the batch, or a full batch of them.
    #[test]
    fn complex_mul_gradient(
        (a, b) in (sizes(), any::<bool>()).prop_flat_map(|((n, h, w), full)| {
            let bdims = if full { vec![n, h, w, 2] } else { vec![h, w, 2] };
            (complex_tensor(n, h, w), strategies::tensor_of(bdims))
        })
    ) {
        check_gradients(|t, v| t.complex_mul(v[0], v[1]), &[a, b], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    #[test]
    /// `|b| ≥ 0.1` at every entry: nearer 0 the guard dominates, `y` reaches `|a|/(2√eps)`
    /// and the f64 round-off of the central difference (≈ 1e-16·|L|/h) passes the tolerance;
    /// that regime has its own test below, with inputs and a step suited to it.
    fn complex_div_guarded_gradient(
        (a, b) in sizes().prop_flat_map(|(n, h, w)| (complex_tensor(n, h, w), strategies::tensor_of(vec![h, w, 2]).prop_map(away_from_zero)))
    ) {
        check_gradients(|t, v| t.complex_div_guarded(v[0], v[1], 1e-6), &[a, b], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    /// `|b|` between 0 and 10·√eps (one entry exactly 0 in half the cases), where the guard
    /// dominates and `∂y/∂b` reaches `|a|/eps`. As near a zero of a real response, the
    /// spectrum `a` is small too (≈ 1e-3), which keeps `y` and `L` of order one, so the f64
    /// round-off of the central difference (≈ 1e-16·|L|/h) stays far below the tolerance.
    #[test]
    fn complex_div_guarded_gradient_near_zero(
        (a, b, exact_zero) in sizes().prop_flat_map(|(n, h, w)| (
            proptest::collection::vec(-2e-3f64..2e-3, 2 * n * h * w)
                .prop_map(move |v| Tensor::from_vec([n, h, w, 2], v)),
            proptest::collection::vec(-1e-2f64..1e-2, 2 * h * w)
                .prop_map(move |v| Tensor::from_vec([h, w, 2], v)),
            any::<bool>(),
        ))
    ) {
        let mut b = b;
        if exact_zero {
            b.data_mut()[0] = 0.0;
            b.data_mut()[1] = 0.0;
        }
        let div = |t: &mut Tape<f64>, v: &[Var]| t.complex_div_guarded(v[0], v[1], 1e-6);
        // `a` enters linearly: the default step. `b`: a step small against √eps = 1e-3, so
        // the truncation error (≈ h²/|b|²) is ≈ 1e-10 relative.
        check_inputs(div, &[a.clone(), b.clone()], &[true, false], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let cfg = CheckConfig { eps: 1e-8, ..CheckConfig::default() };
        check_inputs(div, &[a, b], &[false, true], &cfg)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    #[test]
    fn pad2d_gradient(
        (x, top, left, extra_h, extra_w) in (strategies::tensor(3), 0usize..3, 0usize..3, 0usize..3, 0usize..3)
    ) {
        let (h, w) = (x.dims()[1], x.dims()[2]);
        check_gradients(|t, v| t.pad2d(v[0], top, left, top + h + extra_h, left + w + extra_w), &[x], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    /// A window `(top, left, h, w)` anywhere inside a `(2, H, W)` tensor (rank 3 and 4).
    #[test]
    fn crop2d_gradient(
        (x, (top, h), (left, w)) in (1usize..=2, 1usize..=6, 1usize..=6).prop_flat_map(|(b, bh, bw)| (
            strategies::tensor_of(if b == 1 { vec![2, bh, bw] } else { vec![b, 2, bh, bw] }),
            (0..bh).prop_flat_map(move |t| (Just(t), 1..=bh - t)),
            (0..bw).prop_flat_map(move |l| (Just(l), 1..=bw - l)),
        ))
    ) {
        check_gradients(|t, v| t.crop2d(v[0], top, left, h, w), &[x], &CheckConfig::default())
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }

    /// The whole W-bucket path: gradients to the image and to the learned response.
    #[test]
    fn fft_convolve_and_deconvolve_same_gradients(
        (x, r) in (1usize..=2, 1usize..=4).prop_flat_map(|(b, n)| (
            strategies::tensor_of(vec![b, 1, n, n]),
            strategies::tensor_of(vec![2 * n - 1, 2 * n - 1, 2]),
        ))
    ) {
        let cfg = CheckConfig::default();
        check_gradients(|t, v| t.fft_convolve_same(v[0], v[1]), &[x.clone(), r.clone()], &cfg)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        // Deconvolution divides by the response's spectrum: next to a spectral zero its
        // derivatives grow as 1/|R|³ and central differences cannot follow them (a response of
        // zeros failed by 6e-6 at |∂| ≈ 1.6e4). So it is checked on spectra kept from zero: the
        // all-pass response plus a quarter of the random one (|R| ≥ 1 − 0.25·2·√2 ≈ 0.29).
        let id = identity_response::<f64>(x.dims()[2]);
        let r = Tensor::from_fn(id.dims(), |i| id.data()[i] + 0.25 * r.data()[i]);
        check_gradients(|t, v| t.fft_deconvolve_same(v[0], v[1], 1e-6), &[x, r], &cfg)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
    }
}

/// The response as a constant (`check_inputs` mask) still lets the image gradient through.
#[test]
fn constant_response_passes_image_gradient() {
    let x = Tensor::from_fn([2, 1, 3, 3], |i| (i as f64 * 0.7).sin());
    let r = identity_response::<f64>(3);
    let rep = check_inputs(
        |t, v| t.fft_convolve_same(v[0], v[1]),
        &[x, r],
        &[true, false],
        &CheckConfig::default(),
    )
    .unwrap();
    assert_eq!(rep.checked, 18);
}

#[test]
fn plans_are_cached() {
    let a = plan::<f32>(37, false);
    let b = plan::<f32>(37, false);
    assert!(Arc::ptr_eq(&a, &b), "a second request re-planned");
    let c = plan::<f32>(37, true);
    assert!(
        !Arc::ptr_eq(&a, &c),
        "forward and inverse plans must differ"
    );
}

#[test]
#[should_panic(expected = "fft2: expected a complex tensor (…, H, W, 2), got (2, 3, 3)")]
fn real_input_panics_with_shape() {
    let mut tape = Tape::<f32>::new();
    let x = tape.constant(Tensor::zeros([2, 3, 3]));
    tape.fft2(x);
}
