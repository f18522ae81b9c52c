//! The x86-64 half of [`super`]: the static kernel tables, the correlation job [`Corr`] that
//! drives [`corr_block`] over a list of positions (forward and `∂x`), and the forward pass.
//! Backward lives in [`super::x86_backward`].

use super::super::kernels::{corr_block, BlockOut, F32x16, F64x8, Simd, Store};
use super::x86_backward::backward;
use super::*;
use rayon::prelude::*;

/// Output channels per forward / `∂x` register block.
pub(super) const MR: usize = 8;
/// Position vectors per forward / `∂x` register block.
const NV: usize = 3;

pub(super) static F32: Table<f32> = Table {
    forward: forward::<F32x16>,
    backward: backward::<F32x16>,
};
pub(super) static F64: Table<f64> = Table {
    forward: forward::<F64x8>,
    backward: backward::<F64x8>,
};

pub(super) fn avx512() {
    assert!(
        std::arch::is_x86_feature_detected!("avx512f"),
        "conv2d: the direct path needs AVX-512F"
    );
}

/// One correlation job: `out` (a channel group, channel stride `out_ch`) over the positions
/// given by `pos(p) = (input offset, output offset, lanes)`, `p < npos`, reading `cin`
/// channels of `inp` (channel stride `in_ch`) with packed weights `w` (blocks of `MR`).
pub(super) struct Corr<'a, S> {
    pub(super) inp: &'a [S],
    pub(super) in_ch: usize,
    pub(super) cin: usize,
    /// Row width of `inp`: tap `(a, b)` reads `a·rw + b` past a position.
    pub(super) rw: usize,
    pub(super) w: &'a [S],
    pub(super) out_ch: usize,
    pub(super) store: Store,
}

impl<S: Float> Corr<'_, S> {
    /// Runs the job on `out` (`channels · out_ch` elements) for `npos` positions.
    pub(super) fn run<V: Simd<S = S>>(
        &self,
        out: &mut [S],
        channels: usize,
        npos: usize,
        pos: impl Fn(usize) -> (usize, usize, usize),
    ) {
        let blocks = channels.div_ceil(MR);
        assert!(out.len() >= channels * self.out_ch && self.w.len() >= blocks * self.cin * 9 * MR);
        if npos == 0 || channels == 0 {
            return;
        }
        // Bounds: positions are increasing in both offsets, so the last one reaches
        // furthest; every store stays inside its channel (`yoff + lanes ≤ out_ch`).
        let (xo, yo, n) = pos(npos - 1);
        assert!(
            (self.cin - 1) * self.in_ch + xo + 2 * self.rw + 2 + V::L <= self.inp.len()
                && yo + n <= self.out_ch,
            "conv2d direct: position out of range"
        );
        // SAFETY: AVX-512F was checked by the caller; the asserts above bound every read of
        // `inp` and `w` and every write of `out` (see `corr_block`).
        unsafe { self.run_unchecked::<V>(out.as_mut_ptr(), channels, npos, pos) }
    }

    #[target_feature(enable = "avx512f")]
    unsafe fn run_unchecked<V: Simd<S = S>>(
        &self,
        out: *mut S,
        channels: usize,
        npos: usize,
        pos: impl Fn(usize) -> (usize, usize, usize),
    ) {
        let blocks = channels.div_ceil(MR);
        let block = |ob: usize| BlockOut {
            ptr: out.add(ob * MR * self.out_ch),
            ch_stride: self.out_ch,
            channels: (channels - ob * MR).min(MR),
            store: self.store,
        };
        let (x, w) = (self.inp.as_ptr(), self.w.as_ptr());
        let taps: [usize; 9] = core::array::from_fn(|t| t / 3 * self.rw + t % 3);
        let mut p = 0;
        while p + NV <= npos {
            let ps: [(usize, usize, usize); NV] = core::array::from_fn(|v| pos(p + v));
            let (xoff, yoff, lanes) = (ps.map(|q| q.0), ps.map(|q| q.1), ps.map(|q| q.2));
            for ob in 0..blocks {
                let wb = w.add(ob * self.cin * 9 * MR);
                corr_block::<V, MR, NV>(
                    x,
                    self.in_ch,
                    self.cin,
                    &taps,
                    wb,
                    &xoff,
                    &yoff,
                    &lanes,
                    block(ob),
                );
            }
            p += NV;
        }
        for p in p..npos {
            let (xo, yo, n) = pos(p);
            for ob in 0..blocks {
                let wb = w.add(ob * self.cin * 9 * MR);
                corr_block::<V, MR, 1>(
                    x,
                    self.in_ch,
                    self.cin,
                    &taps,
                    wb,
                    &[xo],
                    &[yo],
                    &[n],
                    block(ob),
                );
            }
        }
    }
}

fn forward<V: Simd>(a: FwdArgs<'_, V::S>) {
    avx512();
    let (g, co) = (a.g, a.co);
    let (c, h, w, rw) = (g.c, g.h, g.w, g.rw());
    let hw = h * w;
    let batch = a.x.len() / (c * hw);
    let mut wf = Scratch::<V::S>::take(co.div_ceil(MR) * c * 9 * MR);
    pack(co, c, a.w, MR, false, &mut wf);
    let nb = w.div_ceil(V::L);
    let store = if a.relu { Store::SetRelu } else { Store::Set };
    let Some(xp) = a.xp else {
        // One task per image, row strip by row strip through one L2-sized padded buffer.
        let strips = strips(h, c * rw + co * w);
        let tall = strips.iter().map(|&(r0, r1)| r1 - r0).max().unwrap_or(0);
        let plane = (tall + 2 * g.p()) * rw;
        let wf = &*wf;
        a.y.par_chunks_mut(co * hw)
            .zip(a.x.par_chunks(c * hw))
            .for_each(|(y, x)| {
                let mut xs = Scratch::<V::S>::take(c * plane + SLACK);
                xs[c * plane..].fill(zero());
                for &(r0, r1) in &strips {
                    g.pad_rows(x, (r0, r1 + 2 * g.p()), &mut xs, plane);
                    let job = Corr {
                        inp: &xs,
                        in_ch: plane,
                        cin: c,
                        rw,
                        w: wf,
                        out_ch: hw,
                        store,
                    };
                    job.run::<V>(y, co, (r1 - r0) * nb, |p| {
                        let (i, j) = (p / nb, p % nb * V::L);
                        (i * rw + j, (r0 + i) * w + j, (w - j).min(V::L))
                    });
                }
            });
        return;
    };
    let stride = xp_stride(&g);
    assert_eq!(xp.len(), batch * stride, "conv2d direct: xp length");
    let per_group = co.div_ceil(MR).div_ceil(groups(batch, co.div_ceil(MR))) * MR;
    let pos = |p: usize| {
        let (i, j) = (p / nb, p % nb * V::L);
        (i * rw + j, i * w + j, (w - j).min(V::L))
    };
    let wf = &*wf;
    // Each image is padded right before it is convolved, by the same task, so the padded
    // copy is still in L2 when the kernel reads it.
    a.y.par_chunks_mut(co * hw)
        .zip(xp.par_chunks_mut(stride))
        .zip(a.x.par_chunks(c * hw))
        .for_each(|((y, xp), x)| {
            let (img, slack) = xp.split_at_mut(g.padded_len());
            g.pad(x, img);
            slack.fill(zero::<V::S>());
            let xp = &*xp;
            y.par_chunks_mut(per_group * hw)
                .enumerate()
                .for_each(|(gi, yg)| {
                    let job = Corr {
                        inp: xp,
                        in_ch: g.plane(),
                        cin: c,
                        rw,
                        w: &wf[gi * per_group * c * 9..],
                        out_ch: hw,
                        store,
                    };
                    job.run::<V>(yg, yg.len() / hw, h * nb, pos);
                });
        });
}
