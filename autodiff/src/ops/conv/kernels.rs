//! AVX-512 micro-kernels of the direct 3×3 convolution (x86-64 only; driven by
//! [`super::direct`]).
//!
//! Two register-blocked kernels, generic over the lane type [`Simd`] (16 × f32 or 8 × f64 in
//! one 512-bit register), so the f64 gradient checks run the same code as f32 training:
//! - [`corr_block`]: `MR` output channels × `NV` vectors of output positions, held in `MR·NV`
//!   registers while the loop runs over input channels and the 9 taps; each step loads `NV`
//!   input vectors and broadcasts `MR` weights (`MR·NV` FMAs per `NV + MR` loads). Used by the
//!   forward pass (input = padded image) and by `∂x` (input = padded `dy`, flipped kernel).
//! - [`dw_block`]: up to 3 vectors of output channels × up to 3 input channels × the 9 taps
//!   (≤ 27 registers), summed over output pixels: each step loads the channels-last `dy`
//!   vectors of one pixel and broadcasts the input values under each tap. Used by `∂w`.
//! - [`channels_last`]: `dy` transposed to pixel-major order by `L × L` register transposes.
//!
//! Addresses are element offsets into raw pointers; the tails of image rows (width not a
//! multiple of the lane count) are handled by masked stores, so no lane outside a row is
//! written (lanes past the tail are computed from padding or neighbouring rows and dropped).
//!
//! Safety: every function here is `unsafe`. The caller guarantees that the CPU supports
//! AVX-512F (checked by [`super::direct::kernels`] before any kernel is handed out) and that
//! every element a doc comment names lies inside the buffer behind the pointer (the drivers in
//! [`super::direct`] assert the extreme offsets of each call range before entering it).

mod simd;

pub(crate) use simd::{F32x16, F64x8, Simd};

/// `$body` once for each tap `$t = 0, …, 8` as a constant, so that accumulators indexed by the
/// tap stay in registers (a loop over taps is not reliably unrolled).
macro_rules! for_each_tap {
    (|$t:ident| $body:block) => {{
        {
            let $t = 0;
            $body
        }
        {
            let $t = 1;
            $body
        }
        {
            let $t = 2;
            $body
        }
        {
            let $t = 3;
            $body
        }
        {
            let $t = 4;
            $body
        }
        {
            let $t = 5;
            $body
        }
        {
            let $t = 6;
            $body
        }
        {
            let $t = 7;
            $body
        }
        {
            let $t = 8;
            $body
        }
    }};
}

/// How [`corr_block`] writes its results.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Store {
    /// Overwrite.
    Set,
    /// Overwrite with `max(·, 0)`.
    SetRelu,
    /// Add to what is there.
    Add,
}

/// Output side of one [`corr_block`] call.
#[derive(Clone, Copy)]
pub(crate) struct BlockOut<S> {
    /// Output channel 0 of the block.
    pub ptr: *mut S,
    /// Distance between output channels.
    pub ch_stride: usize,
    /// Output channels to store (`≤ MR`; the packed weights of the others are zero).
    pub channels: usize,
    pub store: Store,
}

/// For `v < NV`, `o < out.channels`, `l < lanes[v]`:
/// `out[o·ch_stride + yoff[v] + l] (=|+=) Σ_{c < cin, t < 9} w[(c·9 + t)·MR + o] ·
/// x[c·x_ch + xoff[v] + taps[t] + l]`.
///
/// Reads `x` at every such index for all `l < L` (lanes past `lanes[v]` are computed and
/// dropped), and `w[.. cin·9·MR]`. (The tap loop is left rolled: unrolled, the compiler hoists
/// all 9·NV input loads and runs out of registers.)
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn corr_block<V: Simd, const MR: usize, const NV: usize>(
    x: *const V::S,
    x_ch: usize,
    cin: usize,
    taps: &[usize; 9],
    w: *const V::S,
    xoff: &[usize; NV],
    yoff: &[usize; NV],
    lanes: &[usize; NV],
    out: BlockOut<V::S>,
) {
    let mut acc = [[V::zero(); NV]; MR];
    for c in 0..cin {
        let xc = x.add(c * x_ch);
        let wc = w.add(c * 9 * MR);
        for (t, &tap) in taps.iter().enumerate() {
            let xt = xc.add(tap);
            let xv: [V; NV] = core::array::from_fn(|v| V::load(xt.add(xoff[v])));
            let wt = wc.add(t * MR);
            for (o, acc_o) in acc.iter_mut().enumerate() {
                let wv = V::splat(*wt.add(o));
                for (a, &xv) in acc_o.iter_mut().zip(&xv) {
                    *a = a.fma(wv, xv);
                }
            }
        }
    }
    for (o, acc_o) in acc.iter().enumerate().take(out.channels) {
        let yo = out.ptr.add(o * out.ch_stride);
        for v in 0..NV {
            let (p, n) = (yo.add(yoff[v]), lanes[v]);
            let r = match out.store {
                Store::Set => acc_o[v],
                Store::SetRelu => acc_o[v].relu(),
                Store::Add => V::load_n(p, n).add(acc_o[v]),
            };
            r.store_n(p, n);
        }
    }
}

/// Rows of output pixels for [`dw_block`]: row `r` has `width` pixels, the first at
/// `x_rows[r]` in an input channel and at pixel index `dy_rows[r]` of the channels-last `dy`.
#[derive(Clone, Copy)]
pub(crate) struct Rows<'a> {
    pub x_rows: &'a [usize],
    pub dy_rows: &'a [usize],
    pub width: usize,
}

/// `∂w` of `OV` vectors of output channels × `CB` input channels × 9 taps, with `dyt` the
/// output gradient channels-last (pixel `p`, channel vector `v` at `dyt[p·px + v·L]`) and
/// `x` padded planes of row width `rw`: for `v < OV`, `cb < CB`, tap `t = a·3 + b`, `l < L`:
/// `dwt[cb·9·px + t·px + v·L + l] += Σ_r Σ_{j < width}
/// dyt[(dy_rows[r] + j)·px + v·L + l] · x[cb·x_ch + x_rows[r] + a·rw + b + j]`.
///
/// Accumulates lane-wise (no horizontal sums): `dwt` holds `∂w` as `[c][t][o]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn dw_block<V: Simd, const OV: usize, const CB: usize>(
    x: *const V::S,
    x_ch: usize,
    rw: usize,
    dyt: *const V::S,
    px: usize,
    rows: Rows<'_>,
    dwt: *mut V::S,
) {
    let mut acc = [[[V::zero(); 9]; CB]; OV];
    // Offsets of kernel row `a` of channel `cb` from a pixel's window corner; the column
    // shift `b` becomes a constant displacement.
    let rows_at: [[usize; 3]; CB] =
        core::array::from_fn(|cb| core::array::from_fn(|a| cb * x_ch + a * rw));
    for (&xr, &dr) in rows.x_rows.iter().zip(rows.dy_rows) {
        let (xr, dr) = (x.add(xr), dyt.add(dr * px));
        for j in 0..rows.width {
            // Opaque per pixel: otherwise the compiler notices that tap `b + 1` of pixel `j`
            // is tap `b` of pixel `j + 1`, carries broadcasts across iterations and spills.
            let xj = core::hint::black_box(xr.add(j));
            let dj = dr.add(j * px);
            let d: [V; OV] = core::array::from_fn(|v| V::load(dj.add(v * V::L)));
            for cb in 0..CB {
                for_each_tap!(|t| {
                    let xv = V::splat(*xj.add(rows_at[cb][t / 3] + t % 3));
                    for v in 0..OV {
                        acc[v][cb][t] = acc[v][cb][t].fma(d[v], xv);
                    }
                });
            }
        }
    }
    for (v, acc_v) in acc.iter().enumerate() {
        for (cb, acc_c) in acc_v.iter().enumerate() {
            for (t, a) in acc_c.iter().enumerate() {
                let p = dwt.add((cb * 9 + t) * px + v * V::L);
                V::load(p).add(*a).store_n(p, V::L);
            }
        }
    }
}

/// `dyt[p·co_l + o] = dy[o·stride + p]` for `p < npx`, `o < co` (times `[y > 0]` with `y` at
/// the same index as `dy` when given), zero for `co ≤ o < co_l` (`co_l` a multiple of `L`):
/// `npx` pixels of `dy` (channel stride `stride`) channels-last for [`dw_block`], by `L × L`
/// register transposes.
///
/// Reads `dy` (and `y`) at `o·stride + p`, `o < co`, `p < npx`; writes `dyt[.. npx·co_l]`.
#[inline(always)]
pub(crate) unsafe fn channels_last<V: Simd>(
    dy: *const V::S,
    y: Option<*const V::S>,
    (co, stride): (usize, usize),
    npx: usize,
    co_l: usize,
    dyt: *mut V::S,
) {
    let mut block = [V::zero(); 16];
    let block = &mut block[..V::L];
    for p in (0..npx).step_by(V::L) {
        let np = (npx - p).min(V::L);
        for o in (0..co_l).step_by(V::L) {
            for (k, row) in block.iter_mut().enumerate() {
                *row = if o + k < co {
                    let at = (o + k) * stride + p;
                    let v = V::load_n(dy.add(at), np);
                    match y {
                        Some(y) => v.where_positive(V::load_n(y.add(at), np)),
                        None => v,
                    }
                } else {
                    V::zero()
                };
            }
            V::transpose(block);
            for (k, col) in block.iter().enumerate().take(np) {
                col.store_n(dyt.add((p + k) * co_l + o), V::L);
            }
        }
    }
}
