//! Backward image by image and row strip by row strip (used by
//! [`super::x86_backward::backward`] when there are at least as many images as threads): each
//! task takes a run of consecutive images and, for one strip of rows of one image at a time
//! ([`strips`], about half of L2), pads the strip's `dy` rows, computes their `∂x`, lays them
//! out channels-last, pads the input rows they read and adds their `∂w` into the task's own
//! partial sum. The strip buffers are reused for every strip, so they stay in L2: `dy` and `x`
//! are read from memory once and only `∂x` is written back, instead of each product writing
//! and reading back a whole padded or transposed copy of the image.
//!
//! Determinism: the images are cut into [`DW_PARTS`] runs whatever the thread count, each
//! run's partial `∂w` sums its images (and their strips) in order, and the partials are added
//! in run order.

use super::super::kernels::{Rows, Simd};
use super::x86_backward::{grad_w_group, to_channels_last, GradX, ZRows};
use super::*;
use rayon::prelude::*;

/// Number of image runs (and partial `∂w` sums); fixed so results do not depend on threads.
const DW_PARTS: usize = 4;

/// The backward pass, image by image and strip by strip (see the module docs). A padded
/// input saved by forward is used when each image is one strip (its layout is then the
/// strip's); otherwise, and when none was saved, each strip of the input is padded here.
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
    let (c, h, wd, rw, wz, p) = (g.c, g.h, g.w, g.rw(), g.wz(), g.p());
    let hw = h * wd;
    let batch = x.len() / (c * hw);
    let co_l = co.div_ceil(V::L) * V::L;
    let per = batch.div_ceil(DW_PARTS.min(batch).max(1)).max(1);
    let runs = batch.div_ceil(per);
    let np = c * 9 * co_l;
    let want_w = gw.is_some();
    let packed = gx.is_some().then(|| GradX::new(g, co, w));
    let strips = backward_strips(&g, co, co_l);
    let tall = strips.iter().map(|&(r0, r1)| r1 - r0).max().unwrap_or(0);
    // Strip planes: `dyz` rows r0 .. r1 + 4p, padded rows r0 .. r1 + 2p.
    let (zplane, xplane) = ((tall + 4 * p) * wz, (tall + 2 * p) * rw);
    // With one strip per image, a padded image saved by forward has the strip's layout.
    let saved = xp.filter(|_| strips.len() == 1);
    let stride = xp_stride(&g);
    let gx_runs: Vec<Option<&mut [V::S]>> = match gx {
        Some(gx) => gx.chunks_mut(per * c * hw).map(Some).collect(),
        None => (0..runs).map(|_| None).collect(),
    };
    let mut parts = Scratch::<V::S>::zeroed(if want_w { runs * np } else { 0 });
    let part_runs: Vec<Option<&mut [V::S]>> = match want_w {
        true => parts.chunks_mut(np).map(Some).collect(),
        false => (0..runs).map(|_| None).collect(),
    };
    // Rows of one strip for the ∂w kernel.
    let x_rows: Vec<usize> = (0..tall).map(|i| i * rw).collect();
    let dy_rows: Vec<usize> = (0..tall).map(|i| i * wd).collect();
    gx_runs
        .into_par_iter()
        .zip(part_runs)
        .enumerate()
        .for_each(|(run, (mut gx, mut part))| {
            // Stale values between strip planes and in the slack are read only into lanes
            // that are dropped; the slack is zeroed once anyway.
            let with_slack = |n: usize| {
                let mut s = Scratch::<V::S>::take(if n == 0 { 0 } else { n + SLACK });
                let len = s.len();
                s[len.saturating_sub(SLACK)..].fill(zero());
                s
            };
            let mut zs = with_slack(if packed.is_some() { co * zplane } else { 0 });
            let mut xs = with_slack(if want_w && saved.is_none() {
                c * xplane
            } else {
                0
            });
            let mut dyt = Scratch::<V::S>::take(if want_w { tall * wd * co_l } else { 0 });
            for b in run * per..((run + 1) * per).min(batch) {
                let dy_b = &dy[b * co * hw..][..co * hw];
                let mask_b = mask.map(|y| &y[b * co * hw..][..co * hw]);
                let x_b = &x[b * c * hw..][..c * hw];
                for &(r0, r1) in &strips {
                    if let (Some(gx), Some(packed)) = (gx.as_deref_mut(), &packed) {
                        g.pad_dy_rows(co, dy_b, mask_b, (r0, r1 + 4 * p), &mut zs, zplane);
                        let gx_b = &mut gx[(b - run * per) * c * hw..][..c * hw];
                        let z = ZRows {
                            z: &zs,
                            plane: zplane,
                            rows: (r0, r1),
                        };
                        packed.rows::<V>(z, 0, gx_b, gx_add);
                    }
                    let Some(part) = part.as_deref_mut() else {
                        continue;
                    };
                    to_channels_last::<V>(dy_b, mask_b, co, (r0 * wd, r1 * wd), co_l, &mut dyt);
                    let xs: &[V::S] = match saved {
                        Some(xp) => &xp[b * stride..][..stride],
                        None => {
                            g.pad_rows(x_b, (r0, r1 + 2 * p), &mut xs, xplane);
                            &xs
                        }
                    };
                    let rows = Rows {
                        x_rows: &x_rows[..r1 - r0],
                        dy_rows: &dy_rows[..r1 - r0],
                        width: wd,
                    };
                    // SAFETY: AVX-512F was checked by the caller. Strip row `i < r1 − r0`,
                    // pixel `j` reads `xs` at `c'·xplane + i·rw + j + tap` (`c' < C`, inside
                    // the `r1 − r0 + 2p` padded rows of plane `c'`) and `dyt` at
                    // `(i·W + j)·co_l + o`, `o < co_l` (inside the strip's `(r1 − r0)·W·co_l`
                    // elements); the partial is written at `c'·9·co_l + t·co_l + o < np`.
                    unsafe { grad_w_group::<V>(xs, xplane, 0, &dyt, co_l, &[rows], part, rw) };
                }
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
