//! The numeric micro-kernels of the fused coupling on row blocks `(rows, CHUNK)`: the layer
//! product [`rows`] in register tiles of up to 4 output rows × `TILE` points, the
//! parameter-gradient product [`outer`] as `LANES` partial sums per entry, ReLU and its mask,
//! and `exp`. Generic over the scalar and over `const FMA: bool` (fused multiply-adds, only in
//! builds compiled for a CPU that has them, see [`super::kernel::Isa`]).
//!
//! Loops index fixed-size rows instead of chaining iterator adaptors: everything here must
//! inline into the SIMD builds (an out-of-line helper is compiled for the baseline CPU).

// Index loops over fixed-size arrays are deliberate (see above).
#![allow(clippy::needless_range_loop)]

use super::kernel::CHUNK;
use crate::Float;

/// `x ← max(x, 0)`.
#[inline(always)]
pub(super) fn relu<T: Float>(x: &mut [T]) {
    for v in x {
        *v = if *v > T::zero() { *v } else { T::zero() };
    }
}

/// `g ← g ⊙ [a > 0]`: the ReLU derivative from its output `a` (0 at the kink).
#[inline(always)]
pub(super) fn mask<T: Float>(g: &mut [T], a: &[T]) {
    for (g, &a) in g.iter_mut().zip(a) {
        *g = if a > T::zero() { *g } else { T::zero() };
    }
}

/// `out[k, p] = init[k] + Σ_j w[j, k] · input[j, p]` for `w (J, K)` row-major and row blocks
/// `input (J, CHUNK)`, `out (K, CHUNK)` (`init` zero when `None`).
#[inline(always)]
pub(super) fn rows<T: Float, const FMA: bool, const TILE: usize>(
    w: &[T],
    init: Option<&[T]>,
    input: &[T],
    out: &mut [T],
) {
    let k_out = out.len() / CHUNK;
    let (k4, k2) = (k_out - k_out % 4, k_out - k_out % 2);
    for p0 in (0..CHUNK).step_by(TILE) {
        for k0 in (0..k4).step_by(4) {
            rows_tile::<T, FMA, TILE, 4>(w, init, input, out, k0, p0);
        }
        for k0 in (k4..k2).step_by(2) {
            rows_tile::<T, FMA, TILE, 2>(w, init, input, out, k0, p0);
        }
        for k0 in k2..k_out {
            rows_tile::<T, FMA, TILE, 1>(w, init, input, out, k0, p0);
        }
    }
}

/// Output rows `k0..k0 + KT`, points `p0..p0 + TILE` of [`rows`], summed in registers.
#[inline(always)]
fn rows_tile<T: Float, const FMA: bool, const TILE: usize, const KT: usize>(
    w: &[T],
    init: Option<&[T]>,
    input: &[T],
    out: &mut [T],
    k0: usize,
    p0: usize,
) {
    let k_out = out.len() / CHUNK;
    let mut acc = [[T::zero(); TILE]; KT];
    if let Some(b) = init {
        for kk in 0..KT {
            acc[kk] = [b[k0 + kk]; TILE];
        }
    }
    // Index loops, not iterator adaptors: everything here must inline into the SIMD build.
    for j in 0..input.len() / CHUNK {
        let x: &[T; TILE] = input[j * CHUNK + p0..][..TILE].try_into().unwrap();
        let w = &w[j * k_out + k0..][..KT];
        for (a, &w) in acc.iter_mut().zip(w) {
            for p in 0..TILE {
                a[p] = madd::<T, FMA>(w, x[p], a[p]);
            }
        }
    }
    for kk in 0..KT {
        out[(k0 + kk) * CHUNK + p0..][..TILE].copy_from_slice(&acc[kk]);
    }
}

/// `lanes[(j·K + k)·LANES + l] += Σ_i a[j, i·LANES + l] · b[k, i·LANES + l]` for row blocks
/// `a (J, CHUNK)` and `b (K, CHUNK)`: the `LANES` partial sums of `a·bᵀ`, in register tiles of
/// up to 2 × 4 products.
#[inline(always)]
pub(super) fn outer<T: Float, const FMA: bool, const LANES: usize>(
    lanes: &mut [T],
    a: &[T],
    b: &[T],
) {
    #[cfg(target_arch = "x86_64")]
    if FMA && std::any::TypeId::of::<T>() == std::any::TypeId::of::<f32>() {
        let f32s = |s: &[T]| {
            // SAFETY: T is f32 (same type id), so the slice reinterprets to itself.
            unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<f32>(), s.len()) }
        };
        // SAFETY: as above; FMA builds run only after the AVX2 + FMA check, and the
        // 16-lane build only after the AVX-512F check.
        unsafe {
            let l = std::slice::from_raw_parts_mut(lanes.as_mut_ptr().cast::<f32>(), lanes.len());
            return super::x86::outer(l, f32s(a), f32s(b), LANES == 16);
        }
    }
    let (j_a, k_b) = (a.len() / CHUNK, b.len() / CHUNK);
    let (j2, k4, k2) = (j_a - j_a % 2, k_b - k_b % 4, k_b - k_b % 2);
    for j0 in (0..j2).step_by(2) {
        for k0 in (0..k4).step_by(4) {
            outer_tile::<T, FMA, LANES, 2, 4>(lanes, a, b, j0, k0);
        }
        for k0 in (k4..k2).step_by(2) {
            outer_tile::<T, FMA, LANES, 2, 2>(lanes, a, b, j0, k0);
        }
        for k0 in k2..k_b {
            outer_tile::<T, FMA, LANES, 2, 1>(lanes, a, b, j0, k0);
        }
    }
    for j0 in j2..j_a {
        for k0 in 0..k_b {
            outer_tile::<T, FMA, LANES, 1, 1>(lanes, a, b, j0, k0);
        }
    }
}

/// Rows `j0..j0 + JT` of `a` against rows `k0..k0 + KT` of `b`, for [`outer`].
#[inline(always)]
fn outer_tile<T: Float, const FMA: bool, const LANES: usize, const JT: usize, const KT: usize>(
    lanes: &mut [T],
    a: &[T],
    b: &[T],
    j0: usize,
    k0: usize,
) {
    let k_b = b.len() / CHUNK;
    let (mut ra, mut rb) = ([row(a, j0); JT], [row(b, k0); KT]);
    for jj in 1..JT {
        ra[jj] = row(a, j0 + jj);
    }
    for kk in 1..KT {
        rb[kk] = row(b, k0 + kk);
    }
    let mut acc = [[[T::zero(); LANES]; KT]; JT];
    for i in 0..CHUNK / LANES {
        let i = i * LANES;
        let mut xa = [[T::zero(); LANES]; JT];
        for jj in 0..JT {
            xa[jj].copy_from_slice(&ra[jj][i..i + LANES]);
        }
        let mut xb = [[T::zero(); LANES]; KT];
        for kk in 0..KT {
            xb[kk].copy_from_slice(&rb[kk][i..i + LANES]);
        }
        for jj in 0..JT {
            for kk in 0..KT {
                for l in 0..LANES {
                    acc[jj][kk][l] = madd::<T, FMA>(xa[jj][l], xb[kk][l], acc[jj][kk][l]);
                }
            }
        }
    }
    for jj in 0..JT {
        for kk in 0..KT {
            let dst = &mut lanes[((j0 + jj) * k_b + k0 + kk) * LANES..][..LANES];
            for (d, &v) in dst.iter_mut().zip(&acc[jj][kk]) {
                *d += v;
            }
        }
    }
}

/// Row `j` of a row block.
#[inline(always)]
fn row<T>(block: &[T], j: usize) -> &[T; CHUNK] {
    block[j * CHUNK..(j + 1) * CHUNK].try_into().unwrap()
}

/// `x ← exp(x)`; in the FMA builds for f32 by [`exp_f32`], which vectorises (libm's `expf` is
/// a call per value).
#[inline(always)]
pub(super) fn exp_chunk<T: Float, const FMA: bool>(x: &mut [T; CHUNK]) {
    if FMA && std::any::TypeId::of::<T>() == std::any::TypeId::of::<f32>() {
        // SAFETY: T is f32 (same type id), so the array reinterprets to itself.
        let x = unsafe { &mut *(x as *mut [T; CHUNK]).cast::<[f32; CHUNK]>() };
        for v in x.iter_mut() {
            *v = exp_f32(*v);
        }
    } else {
        for v in x.iter_mut() {
            *v = v.exp();
        }
    }
}

/// `exp(x)` for f32 without branches (Cephes `expf`: Moshier, *Methods and Programs for
/// Mathematical Functions*, 1989): `x = n·ln 2 + r` with `|r| ≤ ln 2 / 2` (`ln 2` split in two
/// for an exact product), `exp(r)` by a degree-7 polynomial, `2ⁿ` built from exponent bits in
/// two halves so that every factor is a normal number. Within 2 units in the last place (test
/// `exp_f32_matches_f64_exp`); `+∞` above `ln(f32::MAX)`, gradual underflow to 0 below
/// `ln(f32::MIN_POSITIVE)`, NaN for NaN. Uses fused multiply-adds: call only in FMA builds.
#[inline(always)]
pub(super) fn exp_f32(x: f32) -> f32 {
    const LN_MAX: f32 = 88.722_84;
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    const P: [f32; 6] = [
        1.987_569_1e-4,
        1.398_199_9e-3,
        8.333_452e-3,
        4.166_579_6e-2,
        0.166_666_65,
        0.5,
    ];
    let xc = x.clamp(-104.0, LN_MAX);
    let n = (xc * std::f32::consts::LOG2_E).round_ties_even();
    let r = n.mul_add(-LN2_LO, n.mul_add(-LN2_HI, xc));
    let mut p = P[0];
    for c in &P[1..] {
        p = p.mul_add(r, *c);
    }
    let e_r = (p * r).mul_add(r, r) + 1.0;
    let k = n as i32;
    let half = k >> 1;
    let pow2 = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
    let y = e_r * pow2(half) * pow2(k - half);
    if x > LN_MAX {
        f32::INFINITY
    } else if x.is_nan() {
        x
    } else {
        y
    }
}

/// `a·b + c`, fused when `FMA`.
#[inline(always)]
pub(super) fn madd<T: Float, const FMA: bool>(a: T, b: T, c: T) -> T {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}
