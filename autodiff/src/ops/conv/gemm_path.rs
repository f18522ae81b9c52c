//! The GEMM lowering of `conv2d` (any odd `k`, any scalar type): the path used when the direct
//! kernels ([`super::direct`]) do not apply — kernels other than 3×3, CPUs without AVX-512F, or
//! on request ([`super::ConvKernel::Gemm`]).
//!
//! Each image is copied once into a padded buffer; the output is then `k²` accumulating faer
//! GEMMs (inner size `Cin`) over shifted strided views of that buffer, per row tile so the
//! working set stays in L2 — no column matrix. Backward computes `∂w` as one GEMM per tile
//! against a column matrix of the tile (`C·k²`-wide result) and `dy` expanded to padded width,
//! and `∂x` as a full correlation of a zero-padded copy of `dy` with the flipped kernel (again
//! `k²` GEMMs per tile), folded back through the adjoint of the padding (reflect borders fold
//! their gradient onto the interior). A 1×1 kernel is one GEMM per image. Images run in
//! parallel on rayon with sequential GEMMs inside; a single image runs on the calling thread so
//! faer may thread its GEMMs. Layouts: see [`super::lowering`].

use super::lowering::{tiles, Geometry};
use super::scratch::Scratch;
use crate::gemm::MatView;
use crate::{BackwardCx, Float, GradSlots, Tensor};
use rayon::prelude::*;

/// Forward pass into `out` (overwritten); returns the padded images for backward (`None` for
/// `k = 1`, which needs no padding).
#[allow(clippy::too_many_arguments)]
pub(super) fn forward<T: Float>(
    g: Geometry,
    batch: usize,
    co: usize,
    x: &Tensor<T>,
    w: &Tensor<T>,
    out: &mut Tensor<T>,
    relu: bool,
) -> Option<Scratch<T>> {
    let (hw, kk, cc) = (g.h * g.w, g.k * g.k, co * g.c);
    let images = out
        .data_mut()
        .chunks_mut(co * hw)
        .zip(x.data().chunks(g.c * hw));
    if g.k == 1 {
        // A 1×1 kernel needs no padding: y_b = W · x_b.
        let ws = w.data();
        for_each_image(
            images,
            || (),
            |_, (y, x)| {
                T::gemm(y, false, ws, false, x, false, co, hw, g.c, T::one());
                if relu {
                    y.iter_mut().for_each(|v| *v = v.max(T::zero()));
                }
            },
        );
        return None;
    }
    let mut wf = Scratch::<T>::take(cc * kk);
    g.forward_weights(co, w.data(), &mut wf);
    let wf = &*wf;
    let tl = tiles(g.h, g.rw() * (co + g.c));
    let max_n = tl
        .iter()
        .map(|&(r0, r1)| (r1 - r0) * g.rw())
        .max()
        .unwrap_or(0);
    let mut saved = Scratch::<T>::take(batch * g.padded_len());
    let images = images.zip(saved.chunks_mut(g.padded_len()));
    let bufs = || Scratch::<T>::take(co * max_n);
    for_each_image(images, bufs, |yt, ((y, x), xp)| {
        g.pad(x, xp);
        for &(r0, r1) in &tl {
            let yt = &mut yt[..co * (r1 - r0) * g.rw()];
            for t in 0..kk {
                let wt = MatView::row_major(&wf[t * cc..][..cc], co, g.c);
                T::gemm_view(yt, t > 0, wt, g.x_view(xp, t, r0, r1), T::one());
            }
            g.compact(yt, r0, r1, y, relu);
        }
    });
    Some(saved)
}

/// One image's share of a backward pass: its `∂x` slot (when wanted), its input, output
/// gradient, ReLU mask (the forward output, when fused) and padded copy saved by [`forward`].
struct ImageGrad<'a, T> {
    gx: Option<&'a mut [T]>,
    x: &'a [T],
    dy: &'a [T],
    mask: Option<&'a [T]>,
    saved_xp: Option<&'a [T]>,
}

/// Backward pass: adds `∂x` and `∂w` into the wanted slots. `saved` holds the padded images
/// [`forward`] returned for this very `x`, when available.
#[allow(clippy::too_many_arguments)]
pub(super) fn backward<T: Float>(
    g: Geometry,
    batch: usize,
    co: usize,
    relu: bool,
    cx: &BackwardCx<'_, T>,
    dx: &mut GradSlots<'_, T>,
    saved: Option<&[T]>,
) {
    let (x, w, dy) = (cx.inputs[0], cx.inputs[1], cx.dy);
    let hw = g.h * g.w;
    let want_w = dx.wants(1);
    let masks: Vec<Option<&[T]>> = if relu {
        cx.output.data().chunks(co * hw).map(Some).collect()
    } else {
        vec![None; batch]
    };
    let saved_xp: Vec<Option<&[T]>> = match saved {
        Some(s) => s.chunks(g.padded_len()).map(Some).collect(),
        None => vec![None; batch],
    };
    let gx: Vec<Option<&mut [T]>> = match dx.slot_data(0) {
        Some(s) => s.chunks_mut(g.c * hw).map(Some).collect(),
        None => (0..batch).map(|_| None).collect(),
    };
    let want_x = gx.first().is_some_and(|g| g.is_some());
    let images = gx
        .into_iter()
        .zip(x.data().chunks(g.c * hw))
        .zip(dy.data().chunks(co * hw))
        .zip(masks)
        .zip(saved_xp)
        .map(|((((gx, x), dy), mask), saved_xp)| ImageGrad {
            gx,
            x,
            dy,
            mask,
            saved_xp,
        });
    let partials: Vec<Scratch<T>> = if g.k == 1 {
        backward_1x1(g, co, relu, w.data(), want_w, images)
    } else {
        let plan = TiledBackward::new(g, co, w.data(), want_w, want_x, saved.is_none());
        let parts = for_each_image_fold(images, || plan.scratch(), |s, im| plan.image(s, im));
        parts.into_iter().map(|(_, dw)| dw).collect()
    };
    if let (true, Some(gw)) = (want_w, dx.slot_data(1)) {
        let mut parts = partials.into_iter();
        if let Some(mut total) = parts.next() {
            for p in parts {
                total.iter_mut().zip(p.iter()).for_each(|(a, &b)| *a += b);
            }
            gw.iter_mut().zip(total.iter()).for_each(|(a, &b)| *a += b);
        }
    }
}

/// Backward of a 1×1 kernel: `∂x_b = Wᵀ·dy_b` and `∂W += dy_b·x_bᵀ` per image (dy masked by the
/// ReLU when fused); returns the per-worker partial sums of `∂W` (`co × C`).
fn backward_1x1<'a, T: Float>(
    g: Geometry,
    co: usize,
    relu: bool,
    ws: &[T],
    want_w: bool,
    images: impl Iterator<Item = ImageGrad<'a, T>> + Send,
) -> Vec<Scratch<T>> {
    let (hw, cc) = (g.h * g.w, co * g.c);
    let bufs = || {
        let masked = if relu { co * hw } else { 0 };
        (Scratch::<T>::zeroed(cc), Scratch::<T>::take(masked))
    };
    let parts = for_each_image_fold(images, bufs, |(dw, dym), im| {
        let dy = match im.mask {
            Some(y) => {
                for ((d, &g), &y) in dym.iter_mut().zip(im.dy).zip(y) {
                    *d = if y > T::zero() { g } else { T::zero() };
                }
                &dym[..]
            }
            None => im.dy,
        };
        if let Some(gx) = im.gx {
            T::gemm(gx, true, ws, true, dy, false, g.c, hw, co, T::one());
        }
        if want_w {
            T::gemm(dw, true, dy, false, im.x, true, co, g.c, hw, T::one());
        }
    });
    parts.into_iter().map(|(dw, _)| dw).collect()
}

/// Per-worker buffers of [`TiledBackward`]: padded image, column matrix with the `dy` tile,
/// zero-padded `dy`, `∂x` tile; and the worker's partial `∂w` (flipped-kernel layout of w).
type TiledScratch<T> = ([Scratch<T>; 4], Scratch<T>);

/// Backward of a `k > 1` kernel, per row tile (module docs): the tiles and flipped weights
/// shared by every image.
struct TiledBackward<T: Float> {
    g: Geometry,
    co: usize,
    want_w: bool,
    want_x: bool,
    /// The padded images must be rebuilt (none saved by the forward).
    repad: bool,
    /// Weights rearranged for the `∂x` correlation (empty unless `want_x`).
    wb: Scratch<T>,
    /// `dy` padded to the padded row width serves directly as the `∂w` GEMM operand.
    wide: bool,
    /// Output row tiles of the `∂w` GEMMs and the largest tile's column count.
    tw: Vec<(usize, usize)>,
    max_w: usize,
    /// Input row tiles of the `∂x` GEMMs (within [`Geometry::grad_rows`]) and the largest
    /// tile's column count.
    tx: Vec<(usize, usize)>,
    max_x: usize,
}

impl<T: Float> TiledBackward<T> {
    /// Plans the tiles and flips the weights (when `∂x` is wanted).
    fn new(g: Geometry, co: usize, w: &[T], want_w: bool, want_x: bool, repad: bool) -> Self {
        let (kk, cc) = (g.k * g.k, co * g.c);
        let mut wb = Scratch::<T>::take(if want_x { cc * kk } else { 0 });
        if want_x {
            g.backward_weights(co, w, &mut wb);
        }
        let wide = g.rw() == g.wz();
        let tw = tiles(g.h, g.rw() * (co + g.c * kk));
        let max_w = tw
            .iter()
            .map(|&(r0, r1)| (r1 - r0) * g.rw())
            .max()
            .unwrap_or(0);
        let (u_lo, u_hi) = g.grad_rows();
        let tx: Vec<(usize, usize)> = tiles(u_hi - u_lo, g.wz() * (co + g.c))
            .into_iter()
            .map(|(a, b)| (a + u_lo, b + u_lo))
            .collect();
        let max_x = tx
            .iter()
            .map(|&(u0, u1)| (u1 - u0) * g.wz())
            .max()
            .unwrap_or(0);
        TiledBackward {
            g,
            co,
            want_w,
            want_x,
            repad,
            wb,
            wide,
            tw,
            max_w,
            tx,
            max_x,
        }
    }

    /// Fresh buffers for one worker, sized for the largest tile.
    fn scratch(&self) -> TiledScratch<T> {
        let (g, co, kk) = (self.g, self.co, self.g.k * self.g.k);
        let (want_w, want_x) = (self.want_w, self.want_x);
        let (xw, xx) = (usize::from(want_w && self.repad), usize::from(want_x));
        (
            [
                Scratch::<T>::take(xw * g.padded_len()),
                Scratch::take(usize::from(want_w) * (g.c * kk + co) * self.max_w),
                Scratch::take(usize::from(want_x || self.wide) * g.dyz_len(co)),
                Scratch::take(xx * g.c * self.max_x),
            ],
            Scratch::<T>::zeroed(usize::from(want_w) * co * g.c * kk),
        )
    }

    /// One image: pads its `dy` (when needed), adds its `∂w` into the worker's partial and its
    /// `∂x` into its slot.
    fn image(&self, (bufs, dwf): &mut TiledScratch<T>, im: ImageGrad<'_, T>) {
        let [xps, dyt, dyz, dxt] = bufs;
        if self.wide || im.gx.is_some() {
            self.g.pad_dy(self.co, im.dy, im.mask, dyz);
        }
        if self.want_w {
            let xp: &[T] = match im.saved_xp {
                Some(xp) => xp,
                None => {
                    self.g.pad(im.x, xps);
                    xps
                }
            };
            self.image_dw(xp, im.dy, im.mask, dyz, dyt, dwf);
        }
        if let Some(gx) = im.gx {
            self.image_dx(dyz, dxt, gx);
        }
    }

    /// `∂w += dy ⋆ x` of one image, one GEMM per `∂w` tile against the tile's column matrix.
    fn image_dw(
        &self,
        xp: &[T],
        dy: &[T],
        mask: Option<&[T]>,
        dyz: &[T],
        dyt: &mut [T],
        dwf: &mut [T],
    ) {
        let (g, co, kk) = (self.g, self.co, self.g.k * self.g.k);
        for &(r0, r1) in &self.tw {
            let n = (r1 - r0) * g.rw();
            let (col, dyt) = dyt.split_at_mut(g.c * kk * n);
            let dyv = if self.wide {
                g.dy_view(co, dyz, r0, r1)
            } else {
                g.expand(co, dy, mask, r0, r1, &mut dyt[..co * n]);
                MatView::row_major(&dyt[..co * n], co, n)
            };
            // One GEMM with a `C·k²`-wide result (k² GEMMs of width C run
            // at half speed); ∂w comes out in the layout of w.
            g.im2col(xp, r0, r1, col);
            let colt = MatView::new(col, 0, n, g.c * kk, 1, n);
            T::gemm_view(dwf, true, dyv, colt, T::one());
        }
    }

    /// `∂x += dy ⋆ flip(w)` of one image: `k²` GEMMs per `∂x` tile over the zero-padded `dy`,
    /// folded back through the adjoint of the padding.
    fn image_dx(&self, dyz: &[T], dxt: &mut [T], gx: &mut [T]) {
        let (g, co, kk, cc) = (self.g, self.co, self.g.k * self.g.k, self.co * self.g.c);
        for &(u0, u1) in &self.tx {
            let dxt = &mut dxt[..g.c * (u1 - u0) * g.wz()];
            for t in 0..kk {
                let wt = MatView::row_major(&self.wb[t * cc..][..cc], g.c, co);
                let z = g.z_view(co, dyz, t, u0, u1);
                T::gemm_view(dxt, t > 0, wt, z, T::one());
            }
            g.fold_rows_add(dxt, u0, u1, gx);
        }
    }
}

/// Runs `f(state, image)` over images: on rayon (one `init()` state per worker split) when
/// there are several, else on the calling thread so that faer may thread each GEMM itself.
pub(crate) fn for_each_image<I, S>(
    images: I,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, I::Item) + Sync + Send,
) where
    I: Iterator + Send,
    I::Item: Send,
    S: Send,
{
    for_each_image_fold(images, init, |s, item| f(s, item));
}

/// Like [`for_each_image`], returning every state used (to reduce per-worker partial sums).
pub(crate) fn for_each_image_fold<I, S>(
    images: I,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, I::Item) + Sync + Send,
) -> Vec<S>
where
    I: Iterator + Send,
    I::Item: Send,
    S: Send,
{
    let items: Vec<I::Item> = images.collect();
    if items.len() < 2 || rayon::current_num_threads() < 2 {
        let mut s = init();
        for item in items {
            f(&mut s, item);
        }
        return vec![s];
    }
    items
        .into_par_iter()
        .fold(&init, |mut s, item| {
            f(&mut s, item);
            s
        })
        .collect()
}
