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

use super::{as_complex, as_complex_mut, complex_dims, gather_columns, plan, with_scratch, COLS};
use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::Fft;
use std::sync::Arc;

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

/// `buf[r·w + c0 + j] = block[j·h + r]`: the inverse of [`gather_columns`].
#[inline(always)]
fn scatter_columns<T: Float>(
    block: &[Complex<T>],
    buf: &mut [Complex<T>],
    (h, w): (usize, usize),
    c0: usize,
    nc: usize,
) {
    for (r, line) in buf.chunks_exact_mut(w).take(h).enumerate() {
        for (j, v) in line[c0..c0 + nc].iter_mut().enumerate() {
            *v = block[j * h + r];
        }
    }
}

/// Row stride of the `H × (W/2 + 1)` half-spectrum buffers: rounded up to whole blocks of
/// [`COLS`] columns, so a block gather reads whole cache lines.
fn half_stride(w: usize) -> usize {
    (w / 2 + 1).next_multiple_of(COLS)
}

/// In-place length-`h` transforms of the columns `0..ncols` of the row-major buffer `buf` of
/// `h` rows of `stride` values, [`COLS`] columns at a time through the contiguous `block`.
fn columns_in_place<T: Float>(
    fft: &dyn Fft<T>,
    buf: &mut [Complex<T>],
    block: &mut [Complex<T>],
    scratch: &mut [Complex<T>],
    (h, stride, ncols): (usize, usize, usize),
) {
    for c0 in (0..ncols).step_by(COLS) {
        let nc = COLS.min(ncols - c0);
        let block = &mut block[..nc * h];
        gather_columns(buf, block, (h, stride), c0, nc);
        fft.process_with_scratch(block, scratch);
        scatter_columns(block, buf, (h, stride), c0, nc);
    }
}

/// `d (=|+=) v · scale`.
#[inline(always)]
fn store<V: Copy + std::ops::Add<Output = V> + std::ops::Mul<T, Output = V>, T: Float>(
    d: &mut V,
    v: V,
    scale: T,
    accumulate: bool,
) {
    *d = if accumulate {
        *d + v * scale
    } else {
        v * scale
    };
}

/// The row (length `w`) and column (length `h`) FFT plans of one direction, and the scratch
/// length either needs in place.
fn row_and_column_plans<T: Float>(
    (h, w): (usize, usize),
    inverse: bool,
) -> (Arc<dyn Fft<T>>, Arc<dyn Fft<T>>, usize) {
    let (fft_w, fft_h) = (plan::<T>(w, inverse), plan::<T>(h, inverse));
    let scratch_len = fft_w
        .get_inplace_scratch_len()
        .max(fft_h.get_inplace_scratch_len());
    (fft_w, fft_h, scratch_len)
}

/// `dst (=|+=) scale · DFT2(src)` (forward sign) for real `H×W` images in `src` and complex
/// (interleaved) full spectra in `dst`.
///
/// Per image, in a thread-local `H × (W/2 + 1)` buffer: pairs of rows as one complex FFT each,
/// separated into the row spectra of columns `0..=W/2`; the column FFTs of that half, in place;
/// then `dst` is written row by row, its columns `l > W/2` from `X[k, l] = conj(X[−k, W − l])`.
pub(crate) fn r2c<T: Float>(
    src: &[T],
    dst: &mut [T],
    (h, w): (usize, usize),
    scale: T,
    accumulate: bool,
) {
    let (plane, half, hs) = (h * w, w / 2 + 1, half_stride(w));
    if plane == 0 || src.is_empty() {
        return;
    }
    assert_eq!(
        2 * src.len(),
        dst.len(),
        "r2c: spectrum and image sizes differ"
    );
    let (fft_w, fft_h, scratch_len) = row_and_column_plans::<T>((h, w), false);
    let half_t = T::of(0.5);
    per_image(src, plane, dst, 2 * plane, |src, dst| {
        let dst = as_complex_mut(dst);
        with_scratch::<T, _>(scratch_len + w + h * hs + COLS * h, |buf| {
            let (scratch, rest) = buf.split_at_mut(scratch_len);
            let (z, rest) = rest.split_at_mut(w);
            // Row spectra of columns 0..=W/2 (H × half, row-major), then the 2-D half spectrum.
            let (rows, block) = rest.split_at_mut(h * hs);
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
                let (ra, rb) = rows[r * hs..].split_at_mut(hs);
                for l in 0..half {
                    let (p, q) = (z[l], z[if l == 0 { 0 } else { w - l }].conj());
                    ra[l] = (p + q) * half_t;
                    if r + 1 < h {
                        let d = (p - q) * half_t;
                        rb[l] = Complex::new(d.im, -d.re);
                    }
                }
            }
            columns_in_place(&*fft_h, rows, block, scratch, (h, hs, half));
            for (k, out) in dst.chunks_exact_mut(w).enumerate() {
                let own = &rows[k * hs..][..half];
                let mirror = &rows[((h - k) % h) * hs..][..half];
                let (lo, hi) = out.split_at_mut(half);
                for (d, &v) in lo.iter_mut().zip(own) {
                    store(d, v, scale, accumulate);
                }
                // hi[j] is column l = half + j, mirrored from column W − l = W − half − j.
                for (d, &v) in hi.iter_mut().zip(mirror[1..=w - half].iter().rev()) {
                    store(d, v.conj(), scale, accumulate);
                }
            }
        });
    });
}

/// `dst (=|+=) scale · Re(IDFT2(src))` (inverse sign, unnormalised) for complex `H×W` spectra
/// in `src` and real images in `dst`.
///
/// Per image, in a thread-local `H × (W/2 + 1)` buffer: the Hermitian part of the columns
/// `0..=W/2`, read row by row (row `k` and row `−k` of `src`); its column IDFTs in place; then
/// each pair of rows, extended by symmetry to full rows, is transformed as `D[r] + i·D[r + 1]`,
/// whose real and imaginary parts are the two real output rows.
pub(crate) fn c2r<T: Float>(
    src: &[T],
    dst: &mut [T],
    (h, w): (usize, usize),
    scale: T,
    accumulate: bool,
) {
    let (plane, half, hs) = (h * w, w / 2 + 1, half_stride(w));
    if plane == 0 || src.is_empty() {
        return;
    }
    assert_eq!(
        src.len(),
        2 * dst.len(),
        "c2r: spectrum and image sizes differ"
    );
    let (fft_w, fft_h, scratch_len) = row_and_column_plans::<T>((h, w), true);
    let half_t = T::of(0.5);
    per_image(src, 2 * plane, dst, plane, |src, dst| {
        let src = as_complex(src);
        with_scratch::<T, _>(scratch_len + w + h * hs + COLS * h, |buf| {
            let (scratch, rest) = buf.split_at_mut(scratch_len);
            let (z, rest) = rest.split_at_mut(w);
            // The Hermitian part of columns 0..=W/2 (H × half, row-major), then its column IDFTs.
            let (hh, block) = rest.split_at_mut(h * hs);
            for (k, out) in hh.chunks_exact_mut(hs).enumerate() {
                let a = &src[k * w..][..w];
                let b = &src[((h - k) % h) * w..][..w];
                out[0] = (a[0] + b[0].conj()) * half_t;
                for ((o, &av), &bv) in out[1..]
                    .iter_mut()
                    .zip(&a[1..])
                    .zip(b[w + 1 - half..].iter().rev())
                {
                    *o = (av + bv.conj()) * half_t;
                }
            }
            columns_in_place(&*fft_h, hh, block, scratch, (h, hs, half));
            // Row r of D is Hermitian: D[r, l] = conj(D[r, W − l]) for the columns l ≥ half.
            let m = w - half;
            for r in (0..h).step_by(2) {
                let x = &hh[r * hs..][..half];
                let (lo, hi) = z.split_at_mut(half);
                if r + 1 < h {
                    // Pack: z = D[r] + i·D[r + 1].
                    let y = &hh[(r + 1) * hs..][..half];
                    let pack =
                        |a: Complex<T>, b: Complex<T>| Complex::new(a.re - b.im, a.im + b.re);
                    for ((zc, &a), &b) in lo.iter_mut().zip(x).zip(y) {
                        *zc = pack(a, b);
                    }
                    let mirrored = x[1..=m].iter().rev().zip(y[1..=m].iter().rev());
                    for (zc, (a, b)) in hi.iter_mut().zip(mirrored) {
                        *zc = pack(a.conj(), b.conj());
                    }
                } else {
                    lo.copy_from_slice(x);
                    for (zc, a) in hi.iter_mut().zip(x[1..=m].iter().rev()) {
                        *zc = a.conj();
                    }
                }
                fft_w.process_with_scratch(z, scratch);
                for (d, zc) in dst[r * w..][..w].iter_mut().zip(z.iter()) {
                    store(d, zc.re, scale, accumulate);
                }
                if r + 1 < h {
                    for (d, zc) in dst[(r + 1) * w..][..w].iter_mut().zip(z.iter()) {
                        store(d, zc.im, scale, accumulate);
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

    fn overwrites_output(&self) -> bool {
        true
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

#[cfg(test)]
mod tests;
