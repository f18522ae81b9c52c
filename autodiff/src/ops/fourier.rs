//! Fourier-domain ops for the W bucket (authors' code, docs/references.md#w-bucket): 2-D FFT and inverse FFT, complex
//! pointwise multiply and guarded divide, moves in and out of the complex domain, zero-padding
//! and cropping, and the "same-size linear convolution" composition the cortex calls.
//!
//! Layout and conventions:
//! - **Complex tensors** carry a trailing axis of length 2, `(re, im)`: a batch of complex images
//!   is `(…, H, W, 2)`, any number of leading batch axes (rank ≥ 3).
//! - [`Tape::fft2`] is the unnormalised DFT over the axes `H, W`:
//!   `X[k, l] = Σ_{y, x} x[y, x] · exp(−2πi (k·y/H + l·x/W))`.
//!   [`Tape::ifft2`] is its inverse, normalised by `1/(H·W)` (NumPy/PyTorch `norm="backward"`).
//! - **Gradients of complex values** are stored the same way: `(∂L/∂re, ∂L/∂im)`. For a
//!   complex-linear map `y = A·x` the backward is `g_x = Aᴴ·g_y`, so the backward of `fft2` is
//!   the *unnormalised* inverse DFT of `g_y` and the backward of `ifft2` is `fft2(g_y)/(H·W)`.
//! - FFTs run on rustfft: rows in place, then columns through a blocked transpose. Plans are
//!   cached per (scalar type, length, direction) for the life of the process, and every rayon
//!   worker keeps its own scratch buffer, so repeated calls neither re-plan nor allocate.
//!   Images of a batch are transformed in parallel.
//!
//! Submodules: [`complex`] (to/from complex, multiply, guarded divide), [`real`] (`fft2_real`,
//! `ifft2_real`: the same transforms with a real input or output, at half the cost), [`pad`]
//! (zero-pad and crop of the last two axes) and [`convolve`] (FFT convolution and deconvolution of real images
//! at their own size, the W-bucket responses).

pub mod complex;
pub mod convolve;
pub mod pad;
pub mod real;

pub use convolve::{identity_response, kernel_response, response_kernel};

use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::any::{Any, TypeId};
use std::cell::RefCell;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// Names of the ops in this family (see the registry rule in [`crate::ops`]).
pub const OPS: &[&str] = &[
    "fft2",
    "ifft2",
    "fft2_real",
    "ifft2_real",
    "to_complex",
    "real_part",
    "complex_mul",
    "complex_div_guarded",
    "pad2d",
    "crop2d",
];

/// Views interleaved `(re, im)` scalars as complex numbers.
pub(crate) fn as_complex<T: Float>(x: &[T]) -> &[Complex<T>] {
    assert!(
        x.len().is_multiple_of(2),
        "as_complex: odd length {}",
        x.len()
    );
    // SAFETY: `Complex<T>` is `#[repr(C)] { re: T, im: T }`: two `T`s, alignment of `T`. The
    // slice holds `len / 2` such pairs, and the lifetime is tied to `x`.
    unsafe { std::slice::from_raw_parts(x.as_ptr().cast(), x.len() / 2) }
}

/// Mutable form of [`as_complex`].
pub(crate) fn as_complex_mut<T: Float>(x: &mut [T]) -> &mut [Complex<T>] {
    assert!(
        x.len().is_multiple_of(2),
        "as_complex_mut: odd length {}",
        x.len()
    );
    // SAFETY: as in `as_complex`; the exclusive borrow of `x` is moved into the result.
    unsafe { std::slice::from_raw_parts_mut(x.as_mut_ptr().cast(), x.len() / 2) }
}

/// `(batch, H, W)` of a complex tensor `(…, H, W, 2)`; panics naming `op` otherwise.
#[track_caller]
pub(crate) fn complex_dims(op: &str, s: Shape) -> (usize, usize, usize) {
    let d = s.dims();
    assert!(
        d.len() >= 3 && d[d.len() - 1] == 2,
        "{op}: expected a complex tensor (…, H, W, 2), got {s:?}"
    );
    let (h, w) = (d[d.len() - 3], d[d.len() - 2]);
    (s.numel() / (2 * h * w).max(1), h, w)
}

type PlanKey = (TypeId, usize, bool);

/// The cached rustfft plan for `len` points (forward, or inverse without normalisation).
fn plan<T: Float>(len: usize, inverse: bool) -> Arc<dyn Fft<T>> {
    static CACHE: OnceLock<Mutex<HashMap<PlanKey, Box<dyn Any + Send + Sync>>>> = OnceLock::new();
    let mut cache = CACHE
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let entry = cache
        .entry((TypeId::of::<T>(), len, inverse))
        .or_insert_with(|| {
            let mut planner = FftPlanner::<T>::new();
            let fft = if inverse {
                planner.plan_fft_inverse(len)
            } else {
                planner.plan_fft_forward(len)
            };
            Box::new(fft)
        });
    entry
        .downcast_ref::<Arc<dyn Fft<T>>>()
        .expect("fft plan cache: entry of the wrong type")
        .clone()
}

thread_local! {
    /// One growable complex scratch buffer per scalar type and thread.
    static SCRATCH: RefCell<HashMap<TypeId, Box<dyn Any>>> = RefCell::new(HashMap::new());
}

/// Runs `f` with this thread's scratch buffer of at least `len` complex values.
fn with_scratch<T: Float, R>(len: usize, f: impl FnOnce(&mut [Complex<T>]) -> R) -> R {
    let key = TypeId::of::<T>();
    let mut buf: Vec<Complex<T>> = SCRATCH
        .with(|s| s.borrow_mut().remove(&key))
        .and_then(|b| b.downcast::<Vec<Complex<T>>>().ok())
        .map(|b| *b)
        .unwrap_or_default();
    if buf.len() < len {
        buf.resize(len, Complex::new(T::zero(), T::zero()));
    }
    let r = f(&mut buf[..len]);
    SCRATCH.with(|s| s.borrow_mut().insert(key, Box::new(buf)));
    r
}

/// Columns per block of the column pass: 8 complex `f32` fill one 64-byte cache line, so a
/// block reads and writes whole lines and never depends on the row stride (power-of-two
/// strides thrash a blocked transpose through cache-set conflicts).
const COLS: usize = 8;

/// Copies columns `c0..c0 + nc` of the `h × w` image `src` into `block`, column after column.
#[inline(always)]
fn gather_columns<T: Float>(
    src: &[Complex<T>],
    block: &mut [Complex<T>],
    (h, w): (usize, usize),
    c0: usize,
    nc: usize,
) {
    if nc == COLS {
        let mut cols: [&mut [Complex<T>]; COLS] = Default::default();
        for (slot, col) in cols.iter_mut().zip(block.chunks_exact_mut(h)) {
            *slot = col;
        }
        for (r, line) in src.chunks_exact(w).enumerate() {
            let line: &[Complex<T>; COLS] = line[c0..c0 + COLS].try_into().expect("COLS");
            for j in 0..COLS {
                cols[j][r] = line[j];
            }
        }
    } else {
        for r in 0..h {
            for j in 0..nc {
                block[j * h + r] = src[r * w + c0 + j];
            }
        }
    }
}

/// `dst (nr × cols) (=|+=) scale · src[:, r0..r0 + nr]ᵀ` for the `rows × cols` matrix `src`:
/// the rows `r0..` of the transpose, written row after row (sequential writes, whole-line reads).
fn transpose_rows<T: Float>(
    src: &[Complex<T>],
    dst: &mut [Complex<T>],
    (rows, cols): (usize, usize),
    r0: usize,
    scale: T,
    accumulate: bool,
) {
    let nr = dst.len() / rows.max(1);
    for (c, line) in src.chunks_exact(cols).enumerate() {
        let seg = &line[r0..r0 + nr];
        for (j, &v) in seg.iter().enumerate() {
            let d = &mut dst[j * rows + c];
            *d = if accumulate {
                *d + v * scale
            } else {
                v * scale
            };
        }
    }
}

/// 2-D DFT of every `H×W` complex image of `src` (interleaved `(re, im)`) into `dst`, which is
/// overwritten or, with `accumulate`, added to: `dst (=|+=) scale · DFT2(src)`. `inverse`
/// selects the `+` sign of the exponent (unnormalised; pass `scale = 1/(H·W)`).
///
/// Per image: the row FFTs go from `src` into a thread-local image buffer; then, for each block
/// of [`COLS`] columns, the block is gathered into a contiguous `COLS × H` buffer, transformed,
/// and scattered (scaled, or added) into `dst`. The source is read once and the destination
/// written once; the intermediate passes stay in this thread's cache.
pub(crate) fn dft2<T: Float>(
    src: &[T],
    dst: &mut [T],
    (h, w): (usize, usize),
    inverse: bool,
    scale: T,
    accumulate: bool,
) {
    assert_eq!(
        src.len(),
        dst.len(),
        "dft2: source and destination lengths differ"
    );
    let plane = h * w;
    if plane == 0 || src.is_empty() {
        return;
    }
    let (fft_w, fft_h) = (plan::<T>(w, inverse), plan::<T>(h, inverse));
    let scratch_len = fft_w
        .get_immutable_scratch_len()
        .max(fft_h.get_outofplace_scratch_len());
    let one_image = |(src, dst): (&[T], &mut [T])| {
        let (src, dst) = (as_complex(src), as_complex_mut(dst));
        // When overwriting, `dst` itself holds the row FFTs, which keeps the working set
        // (source, destination, transposed spectrum) within a core's L2 cache at 256².
        let temp = if accumulate { plane } else { 0 };
        with_scratch::<T, _>(scratch_len + plane + temp + COLS * h, |buf| {
            let (scratch, rest) = buf.split_at_mut(scratch_len);
            // `colmaj` is the transposed spectrum (W × H): image column `c` is its row `c`.
            let (colmaj, rest) = rest.split_at_mut(plane);
            let (block, rest) = rest.split_at_mut(COLS * h);
            let rows: &mut [Complex<T>] = if accumulate { rest } else { &mut *dst };
            fft_w.process_immutable_with_scratch(src, rows, scratch);
            for c0 in (0..w).step_by(COLS) {
                let nc = COLS.min(w - c0);
                let block = &mut block[..nc * h];
                gather_columns(rows, block, (h, w), c0, nc);
                let out = &mut colmaj[c0 * h..][..nc * h];
                fft_h.process_outofplace_with_scratch(block, out, scratch);
            }
            for r0 in (0..h).step_by(COLS) {
                let nr = COLS.min(h - r0);
                let out = &mut dst[r0 * w..][..nr * w];
                transpose_rows(colmaj, out, (w, h), r0, scale, accumulate);
            }
        });
    };
    let images = src.len() / (2 * plane);
    if images > 1 && src.len() >= 1 << 12 {
        src.par_chunks(2 * plane)
            .zip(dst.par_chunks_mut(2 * plane))
            .for_each(one_image);
    } else {
        src.chunks(2 * plane)
            .zip(dst.chunks_mut(2 * plane))
            .for_each(one_image);
    }
}

/// `fft2` (forward) or `ifft2` (inverse, normalised) of a complex tensor `(…, H, W, 2)`.
struct Dft2 {
    inverse: bool,
}

impl Dft2 {
    fn scale<T: Float>(&self, h: usize, w: usize) -> T {
        if self.inverse {
            T::of(1.0 / (h * w) as f64)
        } else {
            T::one()
        }
    }
}

impl<T: Float> Op<T> for Dft2 {
    fn name(&self) -> &'static str {
        if self.inverse {
            "ifft2"
        } else {
            "fft2"
        }
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        complex_dims(<Self as Op<T>>::name(self), inputs[0].shape());
        inputs[0].shape()
    }

    fn overwrites_output(&self) -> bool {
        true
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (_, h, w) = complex_dims("fft2", out.shape());
        let scale = self.scale(h, w);
        dft2(
            inputs[0].data(),
            out.data_mut(),
            (h, w),
            self.inverse,
            scale,
            false,
        );
    }

    /// `fft2`: `g_x = conj(F)·g_y` (unnormalised inverse); `ifft2`: `g_x = F·g_y / (H·W)`.
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if !dx.wants(0) {
            return;
        }
        let (_, h, w) = complex_dims("fft2", cx.dy.shape());
        let scale = self.scale(h, w);
        let g = dx.slot_data(0).expect("wanted");
        dft2(cx.dy.data(), g, (h, w), !self.inverse, scale, true);
    }
}

impl<T: Float> Tape<T> {
    /// Unnormalised 2-D DFT over the `H, W` axes of a complex tensor `(…, H, W, 2)`.
    #[track_caller]
    pub fn fft2(&mut self, x: Var) -> Var {
        self.apply(Dft2 { inverse: false }, &[x])
    }

    /// Inverse 2-D DFT, normalised by `1/(H·W)`, of a complex tensor `(…, H, W, 2)`.
    #[track_caller]
    pub fn ifft2(&mut self, x: Var) -> Var {
        self.apply(Dft2 { inverse: true }, &[x])
    }
}

#[cfg(test)]
mod tests;
