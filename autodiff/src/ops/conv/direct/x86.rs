//! The x86-64 half of [`super`]: the static kernel tables, the correlation job [`Corr`] that
//! drives [`corr_block`] over a list of positions (forward and `∂x`), and the forward pass.
//! Backward lives in [`super::x86_backward`].

use super::super::kernels::{corr_block, BlockOut, F32x16, F64x8, Simd, Store};
use super::x86_backward::backward;
use super::*;
use rayon::prelude::*;

/// Output channels per forward / `∂x` register block, and position vectors per block, for
/// channel counts that are not a multiple of [`WIDE_MR`]: `MR·NV` = 24 accumulators, `NV`
/// input loads and `MR` weight broadcasts a tap.
pub(super) const MR: usize = 8;
const NV: usize = 3;
/// Output channels per register block when the channel count is a multiple of it, with one
/// position vector: 16 accumulators, one input load a tap. Most input loads are unaligned
/// (taps `b = 1, 2`) and cross a cache line; one per 16 FMAs instead of three per 24 runs
/// the paper eye's first layer about 13 % faster (`cargo bench --bench conv -- phases`).
const WIDE_MR: usize = 16;

/// The register block height ([`MR`] or [`WIDE_MR`]) for jobs over `channels` output
/// channels (forward) or input channels (`∂x`). Each output's sum runs over the input
/// channels and taps in the same order whatever the block, so results do not depend on it.
pub(super) fn block_rows(channels: usize) -> usize {
    if channels.is_multiple_of(WIDE_MR) {
        WIDE_MR
    } else {
        MR
    }
}

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
/// channels of `inp` (channel stride `in_ch`) with packed weights `w` (blocks of `mr`).
pub(super) struct Corr<'a, S> {
    pub(super) inp: &'a [S],
    pub(super) in_ch: usize,
    pub(super) cin: usize,
    /// Row width of `inp`: tap `(a, b)` reads `a·rw + b` past a position.
    pub(super) rw: usize,
    pub(super) w: &'a [S],
    /// Channels per packed weight block: [`block_rows`] of the job's channel count.
    pub(super) mr: usize,
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
        let mr = self.mr;
        assert!(
            mr == MR || mr == WIDE_MR,
            "conv2d direct: block of {mr} channels"
        );
        let blocks = channels.div_ceil(mr);
        assert!(out.len() >= channels * self.out_ch && self.w.len() >= blocks * self.cin * 9 * mr);
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
        unsafe {
            match mr {
                WIDE_MR => {
                    self.run_unchecked::<V, WIDE_MR, 1>(out.as_mut_ptr(), channels, npos, pos)
                }
                _ => self.run_unchecked::<V, MR, NV>(out.as_mut_ptr(), channels, npos, pos),
            }
        }
    }

    #[target_feature(enable = "avx512f")]
    unsafe fn run_unchecked<V: Simd<S = S>, const ROWS: usize, const VECS: usize>(
        &self,
        out: *mut S,
        channels: usize,
        npos: usize,
        pos: impl Fn(usize) -> (usize, usize, usize),
    ) {
        let blocks = channels.div_ceil(ROWS);
        let block = |ob: usize| BlockOut {
            ptr: out.add(ob * ROWS * self.out_ch),
            ch_stride: self.out_ch,
            channels: (channels - ob * ROWS).min(ROWS),
            store: self.store,
        };
        let (x, w) = (self.inp.as_ptr(), self.w.as_ptr());
        let taps: [usize; 9] = core::array::from_fn(|t| t / 3 * self.rw + t % 3);
        let mut p = 0;
        while p + VECS <= npos {
            let ps: [(usize, usize, usize); VECS] = core::array::from_fn(|v| pos(p + v));
            let (xoff, yoff, lanes) = (ps.map(|q| q.0), ps.map(|q| q.1), ps.map(|q| q.2));
            for ob in 0..blocks {
                let wb = w.add(ob * self.cin * 9 * ROWS);
                corr_block::<V, ROWS, VECS>(
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
            p += VECS;
        }
        for p in p..npos {
            let (xo, yo, n) = pos(p);
            for ob in 0..blocks {
                let wb = w.add(ob * self.cin * 9 * ROWS);
                corr_block::<V, ROWS, 1>(
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
    let mr = block_rows(co);
    let mut wf = Scratch::<V::S>::take(co.div_ceil(mr) * c * 9 * mr);
    pack(co, c, a.w, mr, false, &mut wf);
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
                        mr,
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
    let per_group = channels_per_group(co, batch, mr);
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
                        mr,
                        out_ch: hw,
                        store,
                    };
                    job.run::<V>(yg, yg.len() / hw, h * nb, pos);
                });
        });
}
