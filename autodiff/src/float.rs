//! The scalar type of a tape: `f32` for training speed, `f64` for gradient checks.
//!
//! [`Float`] gathers what every op needs (arithmetic from `num_traits`, FFT support from
//! `rustfft`) and adds the one routine that must be written per type: GEMM on faer.

use std::fmt::{Debug, Display};
use std::iter::Sum;
use std::ops::{AddAssign, DivAssign, MulAssign, SubAssign};

/// A real scalar a [`Tape`](crate::Tape) can hold. Implemented for `f32` and `f64`.
pub trait Float:
    num_traits::Float
    + rustfft::FftNum
    + Default
    + Debug
    + Display
    + Sum
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Send
    + Sync
    + 'static
{
    /// `"f32"` or `"f64"`, used in safetensors headers and error messages.
    const DTYPE: &'static str;

    /// Lossy conversion from `f64` (rounds to nearest for `f32`).
    fn of(x: f64) -> Self;

    /// Exact widening to `f64`.
    fn as_f64(self) -> f64;

    /// `dst[m×n] (=|+=) alpha · op(a) · op(b)` on row-major slices, through faer's GEMM.
    ///
    /// `a` is `m×k` (or `k×m` when `a_transposed`), `b` is `k×n` (or `n×k` when
    /// `b_transposed`); all are contiguous row-major. `accumulate` adds into `dst` instead of
    /// overwriting it. Parallelism follows [`crate::gemm::parallelism`].
    #[allow(clippy::too_many_arguments)]
    fn gemm(
        dst: &mut [Self],
        accumulate: bool,
        a: &[Self],
        a_transposed: bool,
        b: &[Self],
        b_transposed: bool,
        m: usize,
        n: usize,
        k: usize,
        alpha: Self,
    );

    /// `dst[m×n] (=|+=) alpha · a · b` for strided views `a (m×k)` and `b (k×n)` (any strides,
    /// overlapping rows allowed); `dst` is contiguous row-major. See [`crate::gemm::MatView`].
    fn gemm_view(
        dst: &mut [Self],
        accumulate: bool,
        a: crate::gemm::MatView<'_, Self>,
        b: crate::gemm::MatView<'_, Self>,
        alpha: Self,
    );
}

macro_rules! impl_float {
    ($t:ty, $name:literal) => {
        impl Float for $t {
            const DTYPE: &'static str = $name;
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn as_f64(self) -> f64 {
                self as f64
            }
            fn gemm(
                dst: &mut [Self],
                accumulate: bool,
                a: &[Self],
                a_transposed: bool,
                b: &[Self],
                b_transposed: bool,
                m: usize,
                n: usize,
                k: usize,
                alpha: Self,
            ) {
                crate::gemm::gemm_impl::<$t>(
                    dst,
                    accumulate,
                    a,
                    a_transposed,
                    b,
                    b_transposed,
                    m,
                    n,
                    k,
                    alpha,
                );
            }
            fn gemm_view(
                dst: &mut [Self],
                accumulate: bool,
                a: crate::gemm::MatView<'_, Self>,
                b: crate::gemm::MatView<'_, Self>,
                alpha: Self,
            ) {
                crate::gemm::gemm_view_impl::<$t>(dst, accumulate, a, b, alpha);
            }
        }
    };
}
impl_float!(f32, "f32");
impl_float!(f64, "f64");
