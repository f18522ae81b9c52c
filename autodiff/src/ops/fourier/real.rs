//! 2-D FFTs with a real side, at about half the cost of the complex ones.
//!
//! - `fft2_real(x)`: real `(…, H, W)` → the **full** complex spectrum `(…, H, W, 2)`; equal to
//!   `fft2(to_complex(x))`. The full layout (not NumPy's half spectrum) lets it be multiplied by
//!   an unconstrained learned response.
//! - `ifft2_real(X)`: complex `(…, H, W, 2)` → real `(…, H, W)`, the real part of the normalised
//!   inverse, `real_part(ifft2(X))`. `X` need not be Hermitian: only its Hermitian part
//!   `(X[k, l] + conj(X[−k, −l]))/2` reaches the real part, and that is what is transformed.
//!
//! Backward (gradients of complex values as `(∂L/∂re, ∂L/∂im)`, see [`super`]):
//! `fft2_real`: `g_x = Re(conj(F)·g_Y)`, the real part of the unnormalised inverse DFT;
//! `ifft2_real`: `g_X = F·g_y / (H·W)`, the DFT of a real array. So the two ops' forward and
//! backward passes share two kernels, `r2c` and `c2r`.
//!
//! How the half cost comes about: two real rows `a, b` are transformed as one complex row
//! `a + i·b` and separated by symmetry (`A[l] = (Z[l] + conj(Z[−l]))/2`,
//! `B[l] = (Z[l] − conj(Z[−l]))/(2i)`); and only the columns `l ≤ W/2` are transformed, the
//! others following from `X[k, l] = conj(X[−k, −l])`.

use super::{
    as_complex, as_complex_mut, complex_dims, gather_columns, plan, transpose_rows, with_scratch,
    COLS,
};
use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;
use rustfft::num_complex::Complex;

/// Runs `f(src_image, dst_image)` over the images of a batch, in parallel when worthwhile.
fn per_image<A: Sync, B: Send>(
    src: &[A],
    src_len: usize,
    dst: &mut [B],
    dst_len: usize,
    f: impl Fn(&[A], &mut [B]) + Sync,
) {
    let images = src.len() / src_len.max(1);
    if images > 1 && src.len() >= 1 << 12 {
        src.par_chunks(src_len)
            .zip(dst.par_chunks_mut(dst_len))
            .for_each(|(s, d)| f(s, d));
    } else {
        src.chunks(src_len)
            .zip(dst.chunks_mut(dst_len))
            .for_each(|(s, d)| f(s, d));
    }
}

/// `dst (=|+=) scale · DFT2(src)` (forward sign) for real `H×W` images in `src` and complex
/// (interleaved) full spectra in `dst`.
///
/// Per image: pairs of rows as one complex FFT each, separated into the row spectra of columns
/// `0..=W/2`; those columns gathered in blocks and transformed into a transposed (`W × H`)
/// spectrum, whose remaining columns follow by symmetry; then written row by row into `dst`.
pub(crate) fn r2c<T: Float>(
    src: &[T],
    dst: &mut [T],
    (h, w): (usize, usize),
    scale: T,
    accumulate: bool,
) {
    let (plane, half) = (h * w, w / 2 + 1);
    if plane == 0 || src.is_empty() {
        return;
    }
    assert_eq!(
        2 * src.len(),
        dst.len(),
        "r2c: spectrum and image sizes differ"
    );
    let (fft_w, fft_h) = (plan::<T>(w, false), plan::<T>(h, false));
    let scratch_len = fft_w
        .get_inplace_scratch_len()
        .max(fft_h.get_outofplace_scratch_len());
    let half_t = T::of(0.5);
    per_image(src, plane, dst, 2 * plane, |src, dst| {
        let dst = as_complex_mut(dst);
        with_scratch::<T, _>(scratch_len + w + h * half + plane + COLS * h, |buf| {
            let (scratch, rest) = buf.split_at_mut(scratch_len);
            let (z, rest) = rest.split_at_mut(w);
            // Row spectra of columns 0..=W/2: H × half, row-major.
            let (rows, rest) = rest.split_at_mut(h * half);
            // The full spectrum, transposed: W × H (image column l is row l).
            let (colmaj, block) = rest.split_at_mut(plane);
            for r in (0..h).step_by(2) {
                let a = &src[r * w..][..w];
                if r + 1 < h {
                    let b = &src[(r + 1) * w..][..w];
                    for ((zc, &av), &bv) in z.iter_mut().zip(a).zip(b) {
                        *zc = Complex::new(av, bv);
                    }
                } else {
                    for (zc, &av) in z.iter_mut().zip(a) {
                        *zc = Complex::new(av, T::zero());
                    }
                }
                fft_w.process_with_scratch(z, scratch);
                // A[l] = (p + q)/2, B[l] = −i(p − q)/2 with p = Z[l], q = conj(Z[−l]).
                let (ra, rb) = rows[r * half..].split_at_mut(half);
                for l in 0..half {
                    let (p, q) = (z[l], z[if l == 0 { 0 } else { w - l }].conj());
                    ra[l] = (p + q) * half_t;
                    if r + 1 < h {
                        let d = (p - q) * half_t;
                        rb[l] = Complex::new(d.im, -d.re);
                    }
                }
            }
            for l0 in (0..half).step_by(COLS) {
                let nl = COLS.min(half - l0);
                let block = &mut block[..nl * h];
                gather_columns(rows, block, (h, half), l0, nl);
                let out = &mut colmaj[l0 * h..][..nl * h];
                fft_h.process_outofplace_with_scratch(block, out, scratch);
            }
            // X[k, l] = conj(X[−k, W − l]) for the columns l > W/2.
            for l in half..w {
                let (known, rest) = colmaj.split_at_mut(l * h);
                let (from, to) = (&known[(w - l) * h..][..h], &mut rest[..h]);
                to[0] = from[0].conj();
                for (t, f) in to[1..].iter_mut().zip(from[1..].iter().rev()) {
                    *t = f.conj();
                }
            }
            for r0 in (0..h).step_by(COLS) {
                let nr = COLS.min(h - r0);
                let out = &mut dst[r0 * w..][..nr * w];
                transpose_rows(colmaj, out, (w, h), r0, scale, accumulate);
            }
        });
    });
}

/// `dst (=|+=) scale · Re(IDFT2(src))` (inverse sign, unnormalised) for complex `H×W` spectra
/// in `src` and real images in `dst`.
///
/// Per image: the spectrum is transposed (block gathers); the Hermitian part of its columns
/// `0..=W/2` is inverse-transformed; then blocks of rows are gathered back, extended by
/// symmetry to full rows, and transformed in pairs as `D[r] + i·D[r + 1]`, whose real and
/// imaginary parts are the two real output rows.
pub(crate) fn c2r<T: Float>(
    src: &[T],
    dst: &mut [T],
    (h, w): (usize, usize),
    scale: T,
    accumulate: bool,
) {
    let (plane, half) = (h * w, w / 2 + 1);
    if plane == 0 || src.is_empty() {
        return;
    }
    assert_eq!(
        src.len(),
        2 * dst.len(),
        "c2r: spectrum and image sizes differ"
    );
    let (fft_w, fft_h) = (plan::<T>(w, true), plan::<T>(h, true));
    let scratch_len = fft_w
        .get_inplace_scratch_len()
        .max(fft_h.get_inplace_scratch_len());
    let half_t = T::of(0.5);
    per_image(src, 2 * plane, dst, plane, |src, dst| {
        let src = as_complex(src);
        with_scratch::<T, _>(scratch_len + plane + half * h + COLS * w, |buf| {
            let (scratch, rest) = buf.split_at_mut(scratch_len);
            // The spectrum transposed: W × H.
            let (full, rest) = rest.split_at_mut(plane);
            // Column IDFTs of the Hermitian part, columns 0..=W/2: half × H.
            let (colh, rows) = rest.split_at_mut(half * h);
            for c0 in (0..w).step_by(COLS) {
                let nc = COLS.min(w - c0);
                gather_columns(src, &mut full[c0 * h..][..nc * h], (h, w), c0, nc);
            }
            for l in 0..half {
                let a = &full[l * h..][..h];
                let b = &full[if l == 0 { 0 } else { w - l } * h..][..h];
                let col = &mut colh[l * h..][..h];
                col[0] = (a[0] + b[0].conj()) * half_t;
                for ((c, &av), &bv) in col[1..].iter_mut().zip(&a[1..]).zip(b[1..].iter().rev()) {
                    *c = (av + bv.conj()) * half_t;
                }
            }
            fft_h.process_with_scratch(colh, scratch);
            for r0 in (0..h).step_by(COLS) {
                let nr = COLS.min(h - r0);
                let rows = &mut rows[..nr * w];
                for l in 0..half {
                    for (j, &v) in colh[l * h + r0..][..nr].iter().enumerate() {
                        rows[j * w + l] = v;
                    }
                }
                for row in rows.chunks_exact_mut(w) {
                    let (lo, hi) = row.split_at_mut(half);
                    for (t, f) in hi.iter_mut().zip(lo[1..=w - half].iter().rev()) {
                        *t = f.conj();
                    }
                }
                // Pack pairs: z = D[r] + i·D[r + 1], in place of D[r].
                for j in (0..nr).step_by(2) {
                    let (a, b) = rows[j * w..].split_at_mut(w);
                    if j + 1 < nr {
                        for (x, y) in a.iter_mut().zip(&b[..w]) {
                            *x = Complex::new(x.re - y.im, x.im + y.re);
                        }
                    }
                    fft_w.process_with_scratch(a, scratch);
                    let ya = &mut dst[(r0 + j) * w..][..w];
                    for (d, z) in ya.iter_mut().zip(a.iter()) {
                        *d = if accumulate {
                            *d + z.re * scale
                        } else {
                            z.re * scale
                        };
                    }
                    if j + 1 < nr {
                        let yb = &mut dst[(r0 + j + 1) * w..][..w];
                        for (d, z) in yb.iter_mut().zip(a.iter()) {
                            *d = if accumulate {
                                *d + z.im * scale
                            } else {
                                z.im * scale
                            };
                        }
                    }
                }
            }
        });
    });
}

/// `fft2_real` (`inverse = false`) or `ifft2_real` (`inverse = true`).
struct RealDft2 {
    inverse: bool,
}

impl<T: Float> Op<T> for RealDft2 {
    fn name(&self) -> &'static str {
        if self.inverse {
            "ifft2_real"
        } else {
            "fft2_real"
        }
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let s = inputs[0].shape();
        let d = s.dims();
        if self.inverse {
            complex_dims("ifft2_real", s);
            Shape::new(&d[..d.len() - 1])
        } else {
            assert!(
                d.len() >= 2 && d.len() < crate::tensor::MAX_RANK,
                "fft2_real: expected a real tensor (…, H, W) of rank 2–5, got {s:?}"
            );
            let mut out = d.to_vec();
            out.push(2);
            Shape::new(&out)
        }
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let x = inputs[0];
        if self.inverse {
            let (_, h, w) = complex_dims("ifft2_real", x.shape());
            c2r(
                x.data(),
                out.data_mut(),
                (h, w),
                T::of(1.0 / (h * w) as f64),
                false,
            );
        } else {
            let (_, h, w) = complex_dims("fft2_real", out.shape());
            r2c(x.data(), out.data_mut(), (h, w), T::one(), false);
        }
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let Some(g) = dx.slot_data(0) else { return };
        if self.inverse {
            let (_, h, w) = complex_dims("ifft2_real", cx.inputs[0].shape());
            r2c(cx.dy.data(), g, (h, w), T::of(1.0 / (h * w) as f64), true);
        } else {
            let (_, h, w) = complex_dims("fft2_real", cx.dy.shape());
            c2r(cx.dy.data(), g, (h, w), T::one(), true);
        }
    }
}

impl<T: Float> Tape<T> {
    /// The full 2-D spectrum `(…, H, W, 2)` of a real tensor `(…, H, W)`: `fft2(to_complex(x))`
    /// at about half the cost.
    #[track_caller]
    pub fn fft2_real(&mut self, x: Var) -> Var {
        self.apply(RealDft2 { inverse: false }, &[x])
    }

    /// The real part `(…, H, W)` of the normalised inverse 2-D FFT of a complex tensor
    /// `(…, H, W, 2)`: `real_part(ifft2(x))` at about half the cost.
    #[track_caller]
    pub fn ifft2_real(&mut self, x: Var) -> Var {
        self.apply(RealDft2 { inverse: true }, &[x])
    }
}
