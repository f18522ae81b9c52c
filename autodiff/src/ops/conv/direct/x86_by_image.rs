//! Backward image by image (used by [`super::x86_backward::backward`] when there are at least
//! as many images as threads): each task takes a run of consecutive images and, for one image
//! at a time, pads its `dy`, computes its `∂x`, lays its `dy` out channels-last and adds its
//! `∂w` into the task's own partial sum — so an image's `dy`, `dyz`, `dyt`, padded input and
//! `∂x` (about 1 MB for 16 channels at 64²) are still in L2 when the next product reads them,
//! instead of each product streaming the whole batch through memory.
//!
//! Determinism: the images are cut into [`DW_PARTS`] runs whatever the thread count, each
//! run's partial `∂w` sums its images in order, and the partials are added in run order.

use super::super::kernels::{Rows, Simd};
use super::super::lowering::tiles;
use super::x86_backward::{grad_w_group, to_channels_last, GradX};
use super::*;
use rayon::prelude::*;

/// Number of image runs (and partial `∂w` sums); fixed so results do not depend on threads.
const DW_PARTS: usize = 4;

/// The backward pass, image by image (see the module docs).
pub(super) fn backward<V: Simd>(a: BwdArgs<'_, V::S>) {
    let BwdArgs {
        g,
        co,
        x,
        w,
        dy,
        mask,
        xp,
        gx,
        gx_add,
        gw,
    } = a;
    let (c, h, wd, rw) = (g.c, g.h, g.w, g.rw());
    let hw = h * wd;
    let batch = x.len() / (c * hw);
    let co_l = co.div_ceil(V::L) * V::L;
    let (stride, zstride) = (xp_stride(&g), g.dyz_len(co) + SLACK);
    let per = batch.div_ceil(DW_PARTS.min(batch).max(1)).max(1);
    let runs = batch.div_ceil(per);
    let np = c * 9 * co_l;
    let want_w = gw.is_some();
    let packed = gx.is_some().then(|| GradX::new(g, co, w));
    let gx_runs: Vec<Option<&mut [V::S]>> = match gx {
        Some(gx) => gx.chunks_mut(per * c * hw).map(Some).collect(),
        None => (0..runs).map(|_| None).collect(),
    };
    let mut parts = Scratch::<V::S>::zeroed(if want_w { runs * np } else { 0 });
    let part_runs: Vec<Option<&mut [V::S]>> = match want_w {
        true => parts.chunks_mut(np).map(Some).collect(),
        false => (0..runs).map(|_| None).collect(),
    };
    // Rows of one image for the ∂w kernel, in L2-sized tiles.
    let x_rows: Vec<usize> = (0..h).map(|i| i * rw).collect();
    let dy_rows: Vec<usize> = (0..h).map(|i| i * wd).collect();
    let tl = tiles(h, wd * (c + co_l));
    let rows: Vec<Rows<'_>> = tl
        .iter()
        .map(|&(r0, r1)| Rows {
            x_rows: &x_rows[r0..r1],
            dy_rows: &dy_rows[r0..r1],
            width: wd,
        })
        .collect();
    gx_runs
        .into_par_iter()
        .zip(part_runs)
        .enumerate()
        .for_each(|(run, (mut gx, mut part))| {
            let mut dyz = Scratch::<V::S>::take(if packed.is_some() { zstride } else { 0 });
            let mut dyt = Scratch::<V::S>::take(if want_w { hw * co_l } else { 0 });
            let mut own = Scratch::<V::S>::take(if want_w && xp.is_none() { stride } else { 0 });
            for b in run * per..((run + 1) * per).min(batch) {
                let dy_b = &dy[b * co * hw..][..co * hw];
                let mask_b = mask.map(|y| &y[b * co * hw..][..co * hw]);
                if let (Some(gx), Some(packed)) = (gx.as_deref_mut(), &packed) {
                    let (img, slack) = dyz.split_at_mut(g.dyz_len(co));
                    g.pad_dy(co, dy_b, mask_b, img);
                    slack.fill(zero());
                    let gx_b = &mut gx[(b - run * per) * c * hw..][..c * hw];
                    packed.channels::<V>(&dyz, 0, gx_b, gx_add);
                }
                let Some(part) = part.as_deref_mut() else {
                    continue;
                };
                to_channels_last::<V>(dy_b, mask_b, co, co_l, &mut dyt);
                let xp_b: &[V::S] = match xp {
                    Some(xp) => &xp[b * stride..][..stride],
                    None => {
                        let (img, slack) = own.split_at_mut(g.padded_len());
                        g.pad(&x[b * c * hw..][..c * hw], img);
                        slack.fill(zero());
                        &own
                    }
                };
                // SAFETY: AVX-512F was checked by the caller. Row `i`, pixel `j` reads `xp_b`
                // at `c'·plane + i·rw + j + tap` (`c' < C`, inside the padded image of
                // `stride ≥ padded_len` elements) and `dyt` at `(i·W + j)·co_l + o`,
                // `o < co_l` (inside `dyt`, `HW·co_l` elements); the partial is written at
                // `c'·9·co_l + t·co_l + o < np = part.len()`.
                unsafe { grad_w_group::<V>(xp_b, g.plane(), 0, &dyt, co_l, &rows, part, rw) };
            }
        });
    if let Some(gw) = gw {
        // gw[o, c, t] += Σ_runs parts[run][(c·9 + t)·co_l + o], runs in order.
        for (o, gw_o) in gw.chunks_exact_mut(c * 9).enumerate() {
            for (k, v) in gw_o.iter_mut().enumerate() {
                let mut s = *v;
                for part in parts.chunks_exact(np) {
                    s += part[k * co_l + o];
                }
                *v = s;
            }
        }
    }
}
