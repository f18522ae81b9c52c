//! Same-size linear convolution and deconvolution of real images by a learned frequency
//! response: the W bucket of the cortex (authors' code, docs/references.md#w-bucket), composed from the ops of [`super`].
//!
//! Geometry, for an image `x` of `H × W` pixels and a response `R` of shape
//! `(2H − 1, 2W − 1, 2)` (complex, natural FFT order, no `fftshift`):
//! 1. `x` is zero-padded into the `(2H − 1) × (2W − 1)` grid with its top-left pixel at `(0, 0)`;
//! 2. `y = Re(ifft2(fft2(x) · R))` is a circular convolution on that grid (computed with
//!    [`Tape::fft2_real`] and [`Tape::ifft2_real`]; `R` need not be Hermitian, and only the
//!    real part of the result is kept, as in the official code);
//! 3. the result is the `H × W` window at `(H − 1, W − 1)`.
//!
//! With `R = fft2(k)` for a kernel `k` on the grid, this is the zero-padded *linear* convolution
//! `out[i, j] = Σ_{dy, dx} k[H−1+dy, W−1+dx] · x[i − dy, j − dx]`: the kernel's origin is the
//! grid cell `(H − 1, W − 1)` ("centred") and its support may span the whole grid
//! (`|dy| ≤ H − 1`); the `2n − 1` grid is exactly large enough that no circular wrap-around
//! reaches the cropped window. [`identity_response`] is the FFT of a delta at the centre, so the
//! W bucket starts as the identity, as the official code does (an all-pass filter with a linear
//! phase). The official code centres the image instead and `fftshift`s; the learned function
//! class is the same.
//!
//! Deconvolution divides instead of multiplying, guarded:
//! `X·conj(R)/(|R|² + eps)` (docs/references.md#guarded-w-inverse, `eps = 1e-6`). The inverse of a
//! kernel centred at `(H − 1, W − 1)` is centred at `(−(H − 1), −(W − 1))`, so deconvolution
//! places the image at `(H − 1, W − 1)` and crops the window at `(0, 0)` (the mirror of
//! steps 1 and 3). At the identity response it therefore returns exactly `x / (1 + eps)`, and
//! for a well-conditioned `R` it undoes [`Tape::fft_convolve_same`] up to what the crop of the
//! convolution cut off at the image border.

use super::{complex_dims, dft2};
use crate::{Float, Tape, Tensor, Var};

/// The `(H, W)` of the image `x` after checking that `response` is `(2H − 1, 2W − 1, 2)`.
#[track_caller]
fn check_response<T: Float>(tape: &Tape<T>, op: &str, x: Var, response: Var) -> (usize, usize) {
    let (xs, rs) = (tape.shape(x), tape.shape(response));
    let d = xs.dims();
    assert!(
        d.len() >= 2,
        "{op}: expected a real image (…, H, W), got {xs:?}"
    );
    let (h, w) = (d[d.len() - 2], d[d.len() - 1]);
    assert!(
        h > 0 && w > 0 && rs.dims() == [2 * h - 1, 2 * w - 1, 2],
        "{op}: the response must be (2H−1, 2W−1, 2) = ({}, {}, 2) for the image {xs:?}, got {rs:?}",
        2 * h - 1,
        2 * w - 1
    );
    (h, w)
}

impl<T: Float> Tape<T> {
    /// Same-size linear convolution of the real image `x` `(…, H, W)` with the kernel whose
    /// frequency response is `response` `(2H − 1, 2W − 1, 2)`; see the module docs for the
    /// geometry. Differentiable in both. Cost: one real-input FFT and one real-output inverse
    /// FFT of the padded grid (`fft2_real`, `ifft2_real`).
    #[track_caller]
    pub fn fft_convolve_same(&mut self, x: Var, response: Var) -> Var {
        self.frequency_filter_same("fft_convolve_same", x, response, None)
    }

    /// The inverse filter of [`Tape::fft_convolve_same`]: divides the spectrum by `response`,
    /// guarded as `X·conj(R)/(|R|² + eps)`. Differentiable in both.
    #[track_caller]
    pub fn fft_deconvolve_same(&mut self, x: Var, response: Var, eps: f64) -> Var {
        self.frequency_filter_same("fft_deconvolve_same", x, response, Some(eps))
    }

    #[track_caller]
    fn frequency_filter_same(&mut self, op: &str, x: Var, response: Var, eps: Option<f64>) -> Var {
        let (h, w) = check_response(self, op, x, response);
        // Convolution: image at the origin, output window at the kernel centre; deconvolution
        // the mirror image (module docs).
        let (at, crop) = if eps.is_none() { (0, 1) } else { (1, 0) };
        let padded = self.pad2d(x, at * (h - 1), at * (w - 1), 2 * h - 1, 2 * w - 1);
        let spectrum = self.fft2_real(padded);
        let filtered = match eps {
            None => self.complex_mul(spectrum, response),
            Some(eps) => self.complex_div_guarded(spectrum, response, eps),
        };
        let real = self.ifft2_real(filtered);
        self.crop2d(real, crop * (h - 1), crop * (w - 1), h, w)
    }
}

/// The frequency response `(2H − 1, 2W − 1, 2)` of a small real kernel `(k_h, k_w)` (odd sizes,
/// `k_h ≤ 2H − 1`, `k_w ≤ 2W − 1`) whose centre is the origin, for [`Tape::fft_convolve_same`]
/// on `H × W` images.
#[track_caller]
pub fn kernel_response<T: Float>(kernel: &Tensor<f64>, h: usize, w: usize) -> Tensor<T> {
    let (kh, kw) = match kernel.dims() {
        &[kh, kw] => (kh, kw),
        _ => panic!(
            "kernel_response: expected a kernel (k_h, k_w), got {:?}",
            kernel.shape()
        ),
    };
    let (gh, gw) = (2 * h - 1, 2 * w - 1);
    assert!(
        kh % 2 == 1 && kw % 2 == 1 && kh <= gh && kw <= gw,
        "kernel_response: a {kh}×{kw} kernel needs odd sizes no larger than the {gh}×{gw} grid of {h}×{w} images"
    );
    let mut grid = Tensor::<f64>::zeros([gh, gw, 2]);
    let (top, left) = (h - 1 - kh / 2, w - 1 - kw / 2);
    for i in 0..kh {
        for j in 0..kw {
            grid.data_mut()[2 * ((top + i) * gw + left + j)] = kernel.data()[i * kw + j];
        }
    }
    let mut response = Tensor::<f64>::zeros(grid.shape());
    dft2(
        grid.data(),
        response.data_mut(),
        (gh, gw),
        false,
        1.0,
        false,
    );
    response.cast()
}

/// The response of the identity filter for `n × n` images: the FFT of a delta at the centre
/// `(n − 1, n − 1)` of the `(2n − 1)²` grid (authors' code, docs/references.md#w-bucket initialisation, `|R| = 1`).
pub fn identity_response<T: Float>(n: usize) -> Tensor<T> {
    kernel_response(&Tensor::from_vec([1, 1], vec![1.0]), n, n)
}

/// The real `k × k` kernel (odd `k`) around the origin of a response `(2H − 1, 2W − 1, 2)`:
/// the real part of its inverse FFT, cropped. The official code logs the learned W this way
/// with `k = 7`. Inverse of [`kernel_response`] for kernels that fit in `k × k`.
#[track_caller]
pub fn response_kernel<T: Float>(response: &Tensor<T>, k: usize) -> Tensor<f64> {
    let (_, gh, gw) = complex_dims("response_kernel", response.shape());
    assert!(
        response.dims().len() == 3 && gh % 2 == 1 && gw % 2 == 1 && k % 2 == 1 && k <= gh.min(gw),
        "response_kernel: expected a response (2H−1, 2W−1, 2) and an odd k no larger than it, got {:?} and k = {k}",
        response.shape()
    );
    let spectrum: Tensor<f64> = response.cast();
    let mut grid = Tensor::<f64>::zeros(spectrum.shape());
    let scale = 1.0 / (gh * gw) as f64;
    dft2(
        spectrum.data(),
        grid.data_mut(),
        (gh, gw),
        true,
        scale,
        false,
    );
    let (top, left) = ((gh - 1) / 2 - k / 2, (gw - 1) / 2 - k / 2);
    Tensor::from_fn([k, k], |i| {
        grid.data()[2 * ((top + i / k) * gw + left + i % k)]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(shape: &[usize], f: f64) -> Tensor<f64> {
        Tensor::from_fn(shape, |i| {
            (i as f64 * f).sin() + 0.3 * (i as f64 * 0.11).cos()
        })
    }

    /// Direct zero-padded linear convolution of `(planes, h, w)` with an odd `k × k` kernel.
    fn direct(x: &Tensor<f64>, h: usize, w: usize, k: &Tensor<f64>) -> Vec<f64> {
        let ks = k.dims()[0];
        let r = (ks / 2) as isize;
        let planes = x.numel() / (h * w);
        let mut out = vec![0.0; x.numel()];
        for p in 0..planes {
            for i in 0..h as isize {
                for j in 0..w as isize {
                    let mut acc = 0.0;
                    for dy in -r..=r {
                        for dx in -r..=r {
                            let (y, xx) = (i - dy, j - dx);
                            if y >= 0 && y < h as isize && xx >= 0 && xx < w as isize {
                                let kv = k.data()[((r + dy) * ks as isize + r + dx) as usize];
                                acc += kv * x.data()[p * h * w + (y * w as isize + xx) as usize];
                            }
                        }
                    }
                    out[p * h * w + (i * w as isize + j) as usize] = acc;
                }
            }
        }
        out
    }

    #[test]
    fn fft_convolution_with_7x7_kernel_equals_direct_linear_convolution() {
        for (h, w) in [(12, 12), (9, 14), (4, 5)] {
            let x = wave(&[2, 1, h, w], 0.73);
            let k = Tensor::from_fn([7, 7], |i| ((i * 37 % 11) as f64 - 5.0) / 7.0);
            let mut tape = Tape::<f64>::new();
            let (vx, vr) = (
                tape.constant(x.clone()),
                tape.constant(kernel_response(&k, h, w)),
            );
            let y = tape.fft_convolve_same(vx, vr);
            let want = direct(&x, h, w, &k);
            let err = tape
                .value(y)
                .data()
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-6, "{h}×{w}: max |fft − direct| = {err:e}");
            assert_eq!(tape.shape(y).dims(), &[2, 1, h, w]);
        }
    }

    #[test]
    fn identity_response_is_identity_and_all_pass() {
        let n = 16;
        let r = identity_response::<f64>(n);
        assert!(r
            .data()
            .chunks(2)
            .all(|c| (c[0].hypot(c[1]) - 1.0).abs() < 1e-12));
        let x = wave(&[3, 1, n, n], 0.41);
        let mut tape = Tape::<f64>::new();
        let (vx, vr) = (tape.constant(x.clone()), tape.constant(r));
        let y = tape.fft_convolve_same(vx, vr);
        assert!(tape.value(y).max_abs_diff(&x) < 1e-12);
        let z = tape.fft_deconvolve_same(vx, vr, 1e-6);
        let scaled = Tensor::from_fn(x.shape(), |i| x.data()[i] / (1.0 + 1e-6));
        assert!(tape.value(z).max_abs_diff(&scaled) < 1e-12);
    }

    #[test]
    fn response_kernel_recovers_the_kernel() {
        let k = Tensor::from_fn([5, 5], |i| (i as f64 * 0.9).cos());
        let r = kernel_response::<f64>(&k, 8, 8);
        let back = response_kernel(&r, 5);
        assert!(back.max_abs_diff(&k) < 1e-12);
        // A wider window shows the same kernel surrounded by zeros.
        let wider = response_kernel(&r, 7);
        for i in 0..7 {
            for j in 0..7 {
                let inner = (1..6).contains(&i) && (1..6).contains(&j);
                let want = if inner {
                    k.data()[(i - 1) * 5 + j - 1]
                } else {
                    0.0
                };
                assert!((wider.data()[i * 7 + j] - want).abs() < 1e-12, "({i}, {j})");
            }
        }
    }

    #[test]
    #[should_panic(
        expected = "fft_convolve_same: the response must be (2H−1, 2W−1, 2) = (7, 7, 2) for the image (1, 1, 4, 4), got (8, 8, 2)"
    )]
    fn wrong_response_size_panics() {
        let mut tape = Tape::<f32>::new();
        let x = tape.constant(Tensor::zeros([1, 1, 4, 4]));
        let r = tape.constant(Tensor::zeros([8, 8, 2]));
        tape.fft_convolve_same(x, r);
    }
}
