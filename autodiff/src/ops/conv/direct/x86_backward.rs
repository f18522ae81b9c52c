//! Backward of the direct path (see [`super`]): `dy` re-laid out twice — zero-padded planes
//! `dyz` for `∂x`, channels-last `dyt` for `∂w` — then `∂x` (interior by [`Corr`], reflect
//! border ring by [`ring`]) and `∂w` ([`grad_w`]).

use super::super::kernels::{channels_last, dw_block, Rows, Simd, Store};
use super::x86::{avx512, block_rows, Corr};
use super::*;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

mod border;

use border::{pack_ring, ring};

pub(super) fn backward<V: Simd>(a: BwdArgs<'_, V::S>) {
    avx512();
    let (g, co) = (a.g, a.co);
    let (c, h, w) = (g.c, g.h, g.w);
    let hw = h * w;
    let batch = a.x.len() / (c * hw);
    if by_image(batch) && BY_IMAGE.load(Ordering::Relaxed) {
        return super::x86_by_image::backward::<V>(a);
    }
    let mask = |b: usize| a.mask.map(|y| &y[b * co * hw..][..co * hw]);
    if let Some(gx) = a.gx {
        let zstride = g.dyz_len(co) + SLACK;
        let mut dyz = Scratch::<V::S>::take(batch * zstride);
        dyz.par_chunks_mut(zstride)
            .zip(a.dy.par_chunks(co * hw))
            .enumerate()
            .for_each(|(b, (z, dy))| {
                let (img, slack) = z.split_at_mut(g.dyz_len(co));
                g.pad_dy(co, dy, mask(b), img);
                slack.fill(zero());
            });
        grad_x::<V>(g, co, a.w, &dyz, zstride, gx, a.gx_add);
    }
    if let Some(gw) = a.gw {
        let co_l = co.div_ceil(V::L) * V::L;
        let mut dyt = Scratch::<V::S>::take(batch * hw * co_l);
        dyt.par_chunks_mut(hw * co_l)
            .zip(a.dy.par_chunks(co * hw))
            .enumerate()
            .for_each(|(b, (t, dy))| to_channels_last::<V>(dy, mask(b), co, (0, hw), co_l, t));
        let stride = xp_stride(&g);
        let mut own = Scratch::<V::S>::take(if a.xp.is_some() { 0 } else { batch * stride });
        let xp: &[V::S] = match a.xp {
            Some(xp) => xp,
            None => {
                own.par_chunks_mut(stride)
                    .zip(a.x.par_chunks(c * hw))
                    .for_each(|(xp, x)| {
                        let (img, slack) = xp.split_at_mut(g.padded_len());
                        g.pad(x, img);
                        slack.fill(zero());
                    });
                &own
            }
        };
        grad_w::<V>(g, co, batch, xp, stride, &dyt, gw);
    }
}

/// Whether batches of at least as many images as threads take the image-by-image path
/// ([`super::x86_by_image`]); tests switch it off to run the batch-wide path on the same cases.
pub(crate) static BY_IMAGE: AtomicBool = AtomicBool::new(true);

/// Pixels `px0..px1` of one image's `dy` (`Co·HW`) channels-last into `dyt[..(px1 − px0)·co_l]`
/// (see [`channels_last`]).
pub(super) fn to_channels_last<V: Simd>(
    dy: &[V::S],
    mask: Option<&[V::S]>,
    co: usize,
    (px0, px1): (usize, usize),
    co_l: usize,
    dyt: &mut [V::S],
) {
    let hw = dy.len() / co;
    assert!(
        px0 <= px1
            && px1 <= hw
            && dyt.len() >= (px1 - px0) * co_l
            && mask.is_none_or(|y| y.len() == dy.len())
            && co_l.is_multiple_of(V::L)
            && co_l >= co,
        "conv2d direct: channels-last buffer sizes"
    );
    // SAFETY: AVX-512F was checked by `backward`; the asserts bound every index
    // `channels_last` touches (`o·hw + px0 + p < co·hw` for `p < px1 − px0`).
    unsafe {
        let (dy, y) = (dy.as_ptr().add(px0), mask.map(|y| y.as_ptr().add(px0)));
        channels_last_unchecked::<V>(dy, y, (co, hw), px1 - px0, co_l, dyt)
    }
}

#[target_feature(enable = "avx512f")]
unsafe fn channels_last_unchecked<V: Simd>(
    dy: *const V::S,
    y: Option<*const V::S>,
    channels: (usize, usize),
    npx: usize,
    co_l: usize,
    dyt: &mut [V::S],
) {
    channels_last::<V>(dy, y, channels, npx, co_l, dyt.as_mut_ptr());
}

/// `∂x (+)= fold(∂xp)` (added into `gx` when `add`, else overwriting it), `∂xp` = full
/// correlation of `dyz` with the flipped kernel: per image, in parallel over images and
/// channel groups (see [`GradX`]).
#[allow(clippy::too_many_arguments)]
fn grad_x<V: Simd>(
    g: Geometry,
    co: usize,
    w: &[V::S],
    dyz: &[V::S],
    zstride: usize,
    gx: &mut [V::S],
    add: bool,
) {
    let (c, hw) = (g.c, g.h * g.w);
    let batch = gx.len() / (c * hw);
    let packed = GradX::new(g, co, w);
    let per_group = channels_per_group(c, batch, packed.mr);
    gx.par_chunks_mut(c * hw)
        .zip(dyz.par_chunks(zstride))
        .for_each(|(gx, z)| {
            gx.par_chunks_mut(per_group * hw)
                .enumerate()
                .for_each(|(gi, gxg)| packed.channels::<V>(z, gi * per_group, gxg, add));
        });
}

/// `∂x` of one image from its `dyz`, with the weights packed once per call: the interior of
/// `∂xp` (one padded position per pixel) straight into `∂x` by [`Corr`]; under reflect
/// padding the border ring is then added by [`ring`].
pub(super) struct GradX<S: Float> {
    g: Geometry,
    co: usize,
    /// Flipped weights in blocks of `mr` input channels (see `pack`).
    wb: Scratch<S>,
    /// Input channels per block: [`block_rows`] of `C`.
    mr: usize,
    /// Ring weights (see [`pack_ring`]), empty under zero padding.
    wr: Scratch<S>,
    /// Row length of `wr`.
    cl: usize,
}

impl<S: Float> GradX<S> {
    pub(super) fn new(g: Geometry, co: usize, w: &[S]) -> Self {
        let c = g.c;
        let mr = block_rows(c);
        let mut wb = Scratch::<S>::take(c.div_ceil(mr) * co * 9 * mr);
        pack(co, c, w, mr, true, &mut wb);
        let reflect = g.mode == super::super::Padding::Reflect;
        // Room for one full vector past the last channel (16 lanes, the widest): `ring` reads it.
        let cl = c + 16;
        let mut wr = Scratch::<S>::take(if reflect { 9 * co * cl } else { 0 });
        if reflect {
            pack_ring(co, c, w, cl, &mut wr);
        }
        GradX {
            g,
            co,
            wb,
            mr,
            wr,
            cl,
        }
    }

    /// `∂x` of input channels `c0 ..` (as many as `gx` holds; `c0` a multiple of the block
    /// height) of the image whose padded `dy` is `z`: added into `gx` when `add`, else
    /// overwriting it.
    pub(super) fn channels<V: Simd<S = S>>(&self, z: &[S], c0: usize, gx: &mut [S], add: bool) {
        let z = ZRows {
            z,
            plane: self.g.plane_z(),
            rows: (0, self.g.h),
        };
        self.rows::<V>(z, c0, gx, add);
    }

    /// [`GradX::channels`] for the image rows `z.rows` only, from a row strip of `dyz`: the
    /// rows of `gx` outside the strip are not touched, except that under reflect padding the
    /// strip holding image row 0 also folds the top border onto row 1 (so a strip that starts
    /// at row 0 must hold row 1 too, when the image has one).
    pub(super) fn rows<V: Simd<S = S>>(&self, z: ZRows<'_, S>, c0: usize, gx: &mut [S], add: bool) {
        let g = self.g;
        let (wd, wz, p) = (g.w, g.wz(), g.p());
        let hw = g.h * wd;
        let (r0, r1) = z.rows;
        debug_assert!(c0.is_multiple_of(self.mr) && V::L <= 16);
        assert!(
            r0 < r1 && r1 <= g.h && (r1 - r0 >= 2 || r0 > 0 || g.h == 1),
            "conv2d direct: ∂x rows {r0}..{r1} of {}",
            g.h
        );
        let nb = wd.div_ceil(V::L);
        // Pixel (i, j) is padded position (i + p, j + p); its window starts at dyz row
        // i + p, column j + p (`dyz` is padded by 2p), i.e. strip row i − r0 + p.
        let pos = |q: usize| {
            let (i, j) = (q / nb, q % nb * V::L);
            ((i + p) * wz + j + p, (r0 + i) * wd + j, (wd - j).min(V::L))
        };
        let job = Corr {
            inp: z.z,
            in_ch: z.plane,
            cin: self.co,
            rw: wz,
            w: &self.wb[c0 * self.co * 9..],
            mr: self.mr,
            out_ch: hw,
            // The ring (below) adds onto border pixels after this pass.
            store: if add { Store::Add } else { Store::Set },
        };
        job.run::<V>(gx, gx.len() / hw, (r1 - r0) * nb, pos);
        if !self.wr.is_empty() {
            ring::<V>(g, self.co, z, &self.wr, self.cl, c0, gx);
        }
    }
}

/// Rows `rows.0..rows.1` of an image's `∂x` read `dyz` rows `rows.0 .. rows.1 + 4p`: here
/// held in `z`, channel `o` from `o·plane`, `dyz` row `rows.0 + k` at `k·Wz` after that.
#[derive(Clone, Copy)]
pub(super) struct ZRows<'a, S> {
    pub(super) z: &'a [S],
    pub(super) plane: usize,
    pub(super) rows: (usize, usize),
}

/// `∂w += Σ_images Σ_pixels dy ⊗ xp-windows`, vectorised over output channels (`dyt` is
/// `dy` channels-last, `co_l` = `Co` rounded up to the lane count), in parallel over groups
/// of input channels (each task owns its rows of the `[c][t][o]` accumulator).
#[allow(clippy::too_many_arguments)]
fn grad_w<V: Simd>(
    g: Geometry,
    co: usize,
    batch: usize,
    xp: &[V::S],
    stride: usize,
    dyt: &[V::S],
    gw: &mut [V::S],
) {
    let (c, h, w, rw) = (g.c, g.h, g.w, g.rw());
    let co_l = co.div_ceil(V::L) * V::L;
    let x_rows: Vec<usize> = (0..batch * h)
        .map(|r| r / h * stride + r % h * rw)
        .collect();
    let dy_rows: Vec<usize> = (0..batch * h).map(|r| r * w).collect();
    let tl = tiles(batch * h, w * (c + co_l));
    assert!(
        xp.len() >= batch * stride && dyt.len() == batch * h * w * co_l && gw.len() == co * c * 9,
        "conv2d direct: ∂w buffer sizes"
    );
    let mut dwt = Scratch::<V::S>::zeroed(c * 9 * co_l);
    let per = c.div_ceil(rayon::current_num_threads().clamp(1, c));
    dwt.par_chunks_mut(per * 9 * co_l)
        .enumerate()
        .for_each(|(gi, part)| {
            let rows: Vec<Rows<'_>> = tl
                .iter()
                .map(|&(r0, r1)| Rows {
                    x_rows: &x_rows[r0..r1],
                    dy_rows: &dy_rows[r0..r1],
                    width: w,
                })
                .collect();
            // SAFETY: AVX-512F was checked by `backward`. Pixel `j` of row `i` of image `b`
            // reads `xp` at `b·stride + c'·plane + i·rw + j + tap`, inside padded image `b`
            // (the length of `xp` is checked above), and `dyt` at `(b·HW + i·W + j)·co_l +
            // o` with `o < co_l`, inside `dyt`; the accumulator is written at
            // `(c' − c0)·9·co_l + t·co_l + o < part.len()`.
            unsafe { grad_w_group::<V>(xp, g.plane(), gi * per, dyt, co_l, &rows, part, rw) };
        });
    for (o, gw_o) in gw.chunks_exact_mut(c * 9).enumerate() {
        for (k, v) in gw_o.iter_mut().enumerate() {
            *v += dwt[k * co_l + o];
        }
    }
}

/// `∂w` of input channels `c0..` (as many as `part` holds) over all tiles of rows.
#[target_feature(enable = "avx512f")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn grad_w_group<V: Simd>(
    xp: &[V::S],
    plane: usize,
    c0: usize,
    dyt: &[V::S],
    co_l: usize,
    tiles: &[Rows<'_>],
    part: &mut [V::S],
    rw: usize,
) {
    let cn = part.len() / (9 * co_l);
    let (x, d, out) = (xp.as_ptr().add(c0 * plane), dyt.as_ptr(), part.as_mut_ptr());
    let nv = co_l / V::L;
    for &rows in tiles {
        // Blocks of up to 3 channel vectors × (3 / vectors) input channels: ≤ 27 registers.
        let mut v0 = 0;
        while v0 < nv {
            let vn = (nv - v0).min(3);
            let mut c = 0;
            while c < cn {
                let cb = (cn - c).min(3 / vn);
                let (xc, dv) = (x.add(c * plane), d.add(v0 * V::L));
                let o = out.add(c * 9 * co_l + v0 * V::L);
                match (vn, cb) {
                    (1, 1) => dw_block::<V, 1, 1>(xc, plane, rw, dv, co_l, rows, o),
                    (1, 2) => dw_block::<V, 1, 2>(xc, plane, rw, dv, co_l, rows, o),
                    (1, _) => dw_block::<V, 1, 3>(xc, plane, rw, dv, co_l, rows, o),
                    (2, _) => dw_block::<V, 2, 1>(xc, plane, rw, dv, co_l, rows, o),
                    _ => dw_block::<V, 3, 1>(xc, plane, rw, dv, co_l, rows, o),
                }
                c += cb;
            }
            v0 += vn;
        }
    }
}
