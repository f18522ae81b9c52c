//! Reflect padding in `∂x`: the gradient of the border ring of `∂xp` (the padded positions
//! outside the image), folded back onto the image pixels they mirror, vectorised over input
//! channels with ring-ordered weights ([`pack_ring`], [`ring`]).

use super::*;

/// `wr[(t·Co + o)·cl + c] = w[o, c, 8 − t]`, zero for `c ≥ C` (`cl ≥ C + L`).
pub(super) fn pack_ring<S: Float>(co: usize, c: usize, w: &[S], cl: usize, wr: &mut [S]) {
    for (k, row) in wr.chunks_exact_mut(cl).enumerate() {
        let (t, o) = (k / co, k % co);
        for (ci, v) in row.iter_mut().enumerate() {
            *v = if ci < c {
                w[(o * c + ci) * 9 + 8 - t]
            } else {
                S::zero()
            };
        }
    }
}

/// Reflect padding: adds the folded gradient of the border ring of `∂xp` (padded rows 0
/// and `Hp − 1`, padded columns 0 and `Wp − 1`) into `∂x` for input channels
/// `c0..c0 + channels` (`gx` holds those channels of one image), vectorised over channels
/// with the weights of [`pack_ring`]. Only the taps that read inside `dy` are summed. Of a
/// strip of image rows `z.rows`, only the ring positions of those rows: the side columns of
/// padded rows `r0 + p .. r1 + p`, the top row when `r0 = 0`, the bottom row when `r1 = H`.
pub(super) fn ring<V: Simd>(
    g: Geometry,
    co: usize,
    z: ZRows<'_, V::S>,
    wr: &[V::S],
    cl: usize,
    c0: usize,
    gx: &mut [V::S],
) {
    let hw = g.h * g.w;
    let channels = gx.len() / hw;
    let (r0, r1) = z.rows;
    assert!(
        r1 <= g.h
            && z.z.len() >= (co - 1) * z.plane + (r1 - r0 + 4 * g.p()) * g.wz()
            && wr.len() >= 9 * co * cl
            && c0 + channels + V::L <= cl,
        "conv2d direct: ring buffer sizes"
    );
    // SAFETY: AVX-512F was checked by `backward`; the reads of `z` stay inside the `co`
    // strip planes (strip rows `u − r0 + a < r1 − r0 + 4p`, columns `v + b < Wz`), those of
    // `wr` end before `(t·Co + o)·cl + c0 + channels + L ≤ 9·Co·cl` (checked above), and the
    // writes of `gx` are bounds-checked.
    unsafe { ring_unchecked::<V>(g, co, z, wr.as_ptr(), cl, c0, gx) }
}

#[target_feature(enable = "avx512f")]
unsafe fn ring_unchecked<V: Simd>(
    g: Geometry,
    co: usize,
    z: ZRows<'_, V::S>,
    wr: *const V::S,
    cl: usize,
    c0: usize,
    gx: &mut [V::S],
) {
    let (h, p, hp, wp) = (g.h, g.p(), g.hp(), g.wp());
    let (r0, r1) = z.rows;
    // Straight segments of the ring: start (u, v), step, length, and the kernel rows `a`
    // and columns `b` that can read inside `dy` (`dyz` row `u + a` and column `v + b`
    // within `2p .. 2p + H` and `2p .. 2p + W`; the other taps read zeros).
    let top = if r0 == 0 { wp } else { 0 };
    let bottom = if r1 == h { wp } else { 0 };
    let segments = [
        ((0, 0), (0, 1), top, 2 * p..3, 0..3),
        ((hp - 1, 0), (0, 1), bottom, 0..1, 0..3),
        ((p + r0, 0), (1, 0), r1 - r0, 0..3, 2 * p..3),
        ((p + r0, wp - 1), (1, 0), r1 - r0, 0..3, 0..1),
    ];
    for ((u0, v0), (du, dv), len, ta, tb) in segments {
        let seg = Segment {
            z: z.z.as_ptr(),
            row0: r0,
            dir: (du, dv),
            co,
            pz: z.plane,
            wz: g.wz(),
            wr,
            cl,
            c0,
            ta,
            tb,
        };
        let mut k = 0;
        while k < len {
            let at = |k: usize| (u0 + k * du, v0 + k * dv);
            if k + RING_BLOCK <= len {
                seg.block::<V, RING_BLOCK>(g, at(k), gx);
                k += RING_BLOCK;
            } else {
                seg.block::<V, 1>(g, at(k), gx);
                k += 1;
            }
        }
    }
}

/// Ring positions per block of [`Segment::block`].
const RING_BLOCK: usize = 8;

/// One straight segment of the border ring of `∂xp` (see [`ring_unchecked`]).
struct Segment<S> {
    /// `dyz` row `row0` (the strip's first).
    z: *const S,
    row0: usize,
    /// Padded `(Δu, Δv)` between consecutive positions.
    dir: (usize, usize),
    co: usize,
    pz: usize,
    wz: usize,
    wr: *const S,
    cl: usize,
    c0: usize,
    ta: std::ops::Range<usize>,
    tb: std::ops::Range<usize>,
}

impl<S: Float> Segment<S> {
    /// `K` consecutive positions from padded `(u, v)`: their `∂xp` for every channel
    /// vector, folded into `gx`. Needs AVX-512F and the bounds of [`ring`].
    #[inline(always)]
    unsafe fn block<V: Simd<S = S>, const K: usize>(
        &self,
        g: Geometry,
        (u, v): (usize, usize),
        gx: &mut [S],
    ) {
        use super::super::super::lowering::source;
        let (hw, p) = (g.h * g.w, g.p() as isize);
        let channels = gx.len() / hw;
        let base = self.z.add((u - self.row0) * self.wz + v);
        let step = self.dir.0 * self.wz + self.dir.1;
        let mut lanes = [zero::<S>(); 16];
        for cv in (0..channels).step_by(V::L) {
            let mut acc = [V::zero(); K];
            for a in self.ta.clone() {
                for b in self.tb.clone() {
                    let t = a * 3 + b;
                    let w = self.wr.add(t * self.co * self.cl + self.c0 + cv);
                    let zt = base.add(a * self.wz + b);
                    for o in 0..self.co {
                        let wv = V::load(w.add(o * self.cl));
                        let zo = zt.add(o * self.pz);
                        for (k, acc) in acc.iter_mut().enumerate() {
                            *acc = acc.fma(wv, V::splat(*zo.add(k * step)));
                        }
                    }
                }
            }
            let n = (channels - cv).min(V::L);
            for (k, acc) in acc.iter().enumerate() {
                // Padded (u, v) of position k folds onto image pixel (i, j).
                let (uk, vk) = (u + k * self.dir.0, v + k * self.dir.1);
                let i = source(uk as isize - p, g.h, g.mode).unwrap_or(0);
                let j = source(vk as isize - p, g.w, g.mode).unwrap_or(0);
                acc.store_n(lanes.as_mut_ptr(), n);
                for (m, &s) in lanes[..n].iter().enumerate() {
                    gx[(cv + m) * hw + i * g.w + j] += s;
                }
            }
        }
    }
}
