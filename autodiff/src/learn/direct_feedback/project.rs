//! The fixed random projections of [`super::DirectFeedbackAlignment`]: how the output error
//! `e` becomes the feedback `B_k·e` of one hidden layer.
//!
//! Two shapes of layer, batch first:
//! - **features** — activation `(B, p)`, output `(B, m)`: a dense `(m, p)` matrix, the paper's
//!   `B_k` (Nøkland 2016). Entries `N(0, 1/m)`.
//! - **images** — activation `(B, C, H, W)`, output `(B, C_e, H_e, W_e)`: the error is first
//!   resampled to the layer's grid (`ê`: the mean over each `f×f` block when the layer is `f`
//!   times coarser, repetition when it is finer), then a fixed random `k × k` convolution
//!   `K_k` of shape `(C, C_e, k, k)` maps it to the layer's channels, zero-padded, same size:
//!   `δ[c, y, x] = Σ_{c_e, i, j} K[c, c_e, i, j]·ê[c_e, y + i − ⌊k/2⌋, x + j − ⌊k/2⌋]`.
//!   Entries `N(0, 1/(C_e·k²))`. A dense `B` for an image is `C·H·W × C_e·H_e·W_e` entries
//!   (8·64² × 64² = 134 M per layer at the quick cortex); the convolution is the restriction
//!   to a *local*, translation-invariant `B`: the error reaches the units that look at the
//!   place it occurred, each channel through its own random filter, so the feedback has full
//!   spatial rank and differs between channels (a `1 × 1` kernel from a one-channel error
//!   would give every channel the same map times a scalar).
//!
//! Scale (tested): for an error whose entries are uncorrelated with variance `v`, each unit's
//! feedback has expected variance `v` — `m` or `C_e·k²` terms of variance `v/m` or
//! `v/(C_e·k²)` — so `‖B_k·e‖/√(units) ≈ RMS(ê)`, at every layer and every width.

use crate::{Float, Tensor};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// The random matrix or kernel for a layer of activation dims `a` and output dims `e`
/// (batch removed), drawn from `seed`; `kernel_px` is `k`.
#[track_caller]
pub(super) fn draw<T: Float>(
    tag: &str,
    a: &[usize],
    e: &[usize],
    kernel_px: usize,
    seed: u64,
) -> Tensor<T> {
    let dims: Vec<usize> = match (a.len(), e.len()) {
        (1, 1) => vec![e[0], a[0]],
        (3, 3) => vec![a[0], e[0], kernel_px, kernel_px],
        _ => panic!(
            "DirectFeedbackAlignment: tag {tag}: activation (B, {a:?}) and output (B, {e:?}) \
             are neither both (B, features) nor both (B, C, H, W)"
        ),
    };
    // the number of error values summed into one unit's feedback: m, or C_e·k²
    let fan_in: usize = if dims.len() == 2 {
        dims[0]
    } else {
        dims[1..].iter().product()
    };
    let sigma = 1.0 / (fan_in.max(1) as f64).sqrt();
    let mut rng = StdRng::seed_from_u64(key_seed(seed, tag, a, e));
    Tensor::from_fn(dims.as_slice(), |_| {
        let z: f64 = StandardNormal.sample(&mut rng);
        T::of(sigma * z)
    })
}

/// FNV-1a over the tag and both shapes, then SplitMix-style mixing with the seed.
fn key_seed(seed: u64, tag: &str, a: &[usize], e: &[usize]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let dims = a.iter().chain([&usize::MAX]).chain(e.iter());
    for byte in tag.bytes().chain(dims.flat_map(|d| d.to_le_bytes())) {
        h = (h ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
    }
    let mut s = seed ^ h.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    s = (s ^ (s >> 31)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    s ^ (s >> 29)
}

/// Writes `B·e` into `grad` (the activation's shape) for the dense matrix `b` `(m, p)`.
pub(super) fn dense<T: Float>(b: &Tensor<T>, e: &Tensor<T>, grad: &mut Tensor<T>) {
    let (m, p) = (b.dims()[0], b.dims()[1]);
    let batch = grad.dims()[0];
    let (bm, ev) = (b.data(), e.data());
    let g = grad.data_mut();
    for s in 0..batch {
        for (j, gj) in g[s * p..(s + 1) * p].iter_mut().enumerate() {
            *gj = (0..m).map(|r| ev[s * m + r] * bm[r * p + j]).sum();
        }
    }
}

/// The error `e (B, C_e, H_e, W_e)` resampled to an `h × w` grid (module docs).
#[track_caller]
pub(super) fn resample<T: Float>(tag: &str, e: &Tensor<T>, h: usize, w: usize) -> Tensor<T> {
    let d = e.dims();
    let (batch, ce, he, we) = (d[0], d[1], d[2], d[3]);
    let coarser = he.is_multiple_of(h) && we.is_multiple_of(w);
    assert!(
        coarser || (h.is_multiple_of(he) && w.is_multiple_of(we)),
        "DirectFeedbackAlignment: tag {tag}: activation grid {h}×{w} and output grid \
         {he}×{we} are not integer multiples"
    );
    let ev = e.data();
    Tensor::from_fn([batch, ce, h, w], |i| {
        let (x, y, plane) = (i % w, (i / w) % h, i / (w * h));
        let src = &ev[plane * he * we..(plane + 1) * he * we];
        if coarser {
            let (fy, fx) = (he / h, we / w);
            let mut acc = T::zero();
            for yy in y * fy..(y + 1) * fy {
                for xx in x * fx..(x + 1) * fx {
                    acc += src[yy * we + xx];
                }
            }
            acc / T::of((fy * fx) as f64)
        } else {
            src[(y * he / h) * we + x * we / w]
        }
    })
}

/// Writes `K ⋆ ê` into `grad` `(B, C, H, W)` for the kernel `k` `(C, C_e, k, k)` and the
/// resampled error `ê` `(B, C_e, H, W)` (zero padding, same size).
pub(super) fn convolve<T: Float>(k: &Tensor<T>, e_hat: &Tensor<T>, grad: &mut Tensor<T>) {
    let [c_out, c_e, kh, kw] = [k.dims()[0], k.dims()[1], k.dims()[2], k.dims()[3]];
    let gd = grad.dims().to_vec();
    let (batch, h, w) = (gd[0], gd[2], gd[3]);
    let (r, cc) = ((kh / 2) as isize, (kw / 2) as isize);
    let (kv, ev) = (k.data(), e_hat.data());
    let g = grad.data_mut();
    g.iter_mut().for_each(|v| *v = T::zero());
    for b in 0..batch {
        for c in 0..c_out {
            let out = &mut g[(b * c_out + c) * h * w..(b * c_out + c + 1) * h * w];
            for ci in 0..c_e {
                let src = &ev[(b * c_e + ci) * h * w..(b * c_e + ci + 1) * h * w];
                for i in 0..kh {
                    for j in 0..kw {
                        let kval = kv[((c * c_e + ci) * kh + i) * kw + j];
                        let (dy, dx) = (i as isize - r, j as isize - cc);
                        for y in 0..h {
                            let sy = y as isize + dy;
                            if sy < 0 || sy >= h as isize {
                                continue;
                            }
                            let row = &src[sy as usize * w..(sy as usize + 1) * w];
                            let orow = &mut out[y * w..(y + 1) * w];
                            let x0 = (-dx).max(0) as usize;
                            let x1 = (w as isize - dx).min(w as isize).max(0) as usize;
                            for x in x0..x1 {
                                orow[x] += kval * row[(x as isize + dx) as usize];
                            }
                        }
                    }
                }
            }
        }
    }
}
