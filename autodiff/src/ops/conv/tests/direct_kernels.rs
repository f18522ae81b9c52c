//! Tests of the direct kernels of `conv2d`: against the direct loops in f64 and f32 (batch-wide
//! and image by image, over several row strips) and against the GEMM path.

use super::*;

/// `conv2d` / `conv2d_relu` with the given kernel in `T`: value, `∂x` and `∂w` for the
/// cotangent `r`, widened to f64.
fn run_kernel<T: Float>(
    kernel: ConvKernel,
    x: &Tensor<f64>,
    w: &Tensor<f64>,
    r: &Tensor<f64>,
    mode: Padding,
    relu: bool,
) -> [Tensor<f64>; 3] {
    let mut t = Tape::<T>::new();
    let (xv, wv) = (t.leaf(x.cast()), t.leaf(w.cast()));
    let y = t.apply(Conv2d::new(mode, relu).with_kernel(kernel), &[xv, wv]);
    t.backward_from(&[(y, r.cast())], &mut crate::NoHooks);
    let gx = t.grad(xv).unwrap().cast();
    let gw = t.grad(wv).unwrap().cast();
    [t.value(y).cast(), gx, gw]
}

/// Largest `|a − b|` relative to the largest `|b|` (at least 1).
fn rel_diff(a: &Tensor<f64>, b: &Tensor<f64>) -> f64 {
    let scale = b.data().iter().fold(1.0f64, |m, v| m.max(v.abs()));
    a.max_abs_diff(b) / scale
}

#[test]
fn direct_kernels_match_direct_loops_f64_and_f32() {
    // The AVX-512 path against the loops above, in f64 and f32, zero and reflect, with and
    // without the fused ReLU, on shapes whose widths are not multiples of the 16- or 8-lane
    // vectors (tails), whose channel counts are not multiples of the 8-channel output blocks
    // or 16-lane channel vectors, single images (split into channel groups), one-pixel rows
    // and images wide enough for several vectors and for the 8-position border-ring blocks;
    // channel counts that are multiples of 16 take the 16-channel blocks (forward over output
    // channels, ∂x over input channels), the others the 8-channel ones.
    assert!(!direct_conv_available::<f32>(5) && !direct_conv_available::<f64>(1));
    if !direct_conv_available::<f32>(3) || !direct_conv_available::<f64>(3) {
        eprintln!("no AVX-512F on this CPU: the direct kernels fall back to GEMM");
    }
    let shapes = [
        // (batch, cin, h, w, cout)
        (2, 5, 7, 19, 11),
        (1, 9, 3, 33, 17),
        (3, 2, 2, 2, 3),
        (1, 24, 12, 16, 20),
        (2, 17, 20, 8, 9),
        (1, 3, 11, 1, 2),
        (2, 1, 1, 40, 1),
        (5, 3, 9, 21, 18),
        (2, 16, 5, 18, 32),
        (1, 32, 6, 20, 16),
        (3, 48, 4, 17, 7),
    ];
    for (i, &(b, ci, h, wd, co)) in shapes.iter().enumerate() {
        let seed = 100 + 10 * i as u64;
        let x = lcg_tensor(&[b, ci, h, wd], seed);
        let w = lcg_tensor(&[co, ci, 3, 3], seed + 1);
        let r = lcg_tensor(&[b, co, h, wd], seed + 2);
        for mode in [Padding::Zero, Padding::Reflect] {
            if mode == Padding::Reflect && (h < 2 || wd < 2) {
                continue;
            }
            for relu in [false, true] {
                let case = format!("x ({b},{ci},{h},{wd}) → {co} {mode:?} relu {relu}");
                let check = |got: &[Tensor<f64>; 3], tol: f64, dtype: &str| {
                    // Reference under the mask the kernel itself produced (an f32 output
                    // within rounding of 0 may legitimately fall on either side).
                    let rm = match relu {
                        true => Tensor::from_fn(r.shape(), |k| {
                            if got[0].data()[k] > 0.0 {
                                r.data()[k]
                            } else {
                                0.0
                            }
                        }),
                        false => r.clone(),
                    };
                    let y = naive_conv(&x, &w, mode);
                    let y = Tensor::from_fn(y.shape(), |k| match relu {
                        true => y.data()[k].max(0.0),
                        false => y.data()[k],
                    });
                    let (gx, gw) = naive_conv_grads(&x, &w, &rm, mode);
                    for (name, a, b) in [
                        ("y", &got[0], &y),
                        ("dx", &got[1], &gx),
                        ("dw", &got[2], &gw),
                    ] {
                        let d = rel_diff(a, b);
                        assert!(d < tol, "{dtype} {case}: {name} off by {d:e} (relative)");
                    }
                };
                // Backward both batch-wide and image by image (for batches of ≥ 2 images),
                // and (batches of ≥ 2 images, forward and backward) with the default row
                // strips — one per image here — and with strips of 2 rows (and a last one
                // of 1 row for odd heights).
                let default_strip = direct::STRIP_ELEMS.load(Ordering::Relaxed);
                for (by_image, strip) in [(false, default_strip), (true, default_strip), (true, 1)]
                {
                    #[cfg(target_arch = "x86_64")]
                    direct::BY_IMAGE.store(by_image, Ordering::Relaxed);
                    direct::STRIP_ELEMS.store(strip, Ordering::Relaxed);
                    let how = format!("by image {by_image}, strip elements {strip}");
                    let f64s = run_kernel::<f64>(ConvKernel::Direct, &x, &w, &r, mode, relu);
                    check(&f64s, 1e-13, &format!("f64 {how}"));
                    let f32s = run_kernel::<f32>(ConvKernel::Direct, &x, &w, &r, mode, relu);
                    check(&f32s, 1e-5, &format!("f32 {how}"));
                    direct::STRIP_ELEMS.store(default_strip, Ordering::Relaxed);
                }
                #[cfg(target_arch = "x86_64")]
                direct::BY_IMAGE.store(true, Ordering::Relaxed);
            }
        }
    }
}

#[test]
fn gemm_and_direct_kernels_agree() {
    // The two implementations on one U-Net-like layer (reflect, fused ReLU), in f64.
    let x = lcg_tensor(&[2, 8, 16, 24], 31);
    let w = lcg_tensor(&[16, 8, 3, 3], 32);
    let r = lcg_tensor(&[2, 16, 16, 24], 33);
    let a = run_kernel::<f64>(ConvKernel::Gemm, &x, &w, &r, Padding::Reflect, true);
    let b = run_kernel::<f64>(ConvKernel::Direct, &x, &w, &r, Padding::Reflect, true);
    for (a, b) in a.iter().zip(&b) {
        assert!(rel_diff(a, b) < 1e-13);
    }
}
