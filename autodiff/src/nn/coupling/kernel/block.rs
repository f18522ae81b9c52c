//! One coupling's work on blocks of points: the chunked forward, the backward to points and
//! parameters, and the dispatch of both to a build ([`Isa`]).

use super::super::tiles::{exp_chunk, madd};
use super::{Isa, Mlp, Scratch, Transposed, CHUNK};
use crate::Float;

/// One coupling's work on blocks of points: forward, or backward to points and parameters.
pub(in crate::nn::coupling) struct Block<'a, T> {
    /// The forward weights (activations, and the chain to the parameters).
    fwd: Mlp<'a, T>,
    /// Backward: `fwd` transposed.
    back: Option<Transposed<'a, T>>,
    /// Backward: the substituted feedback weights the points' error travels through, when a
    /// learning rule replaced the forward ones.
    feedback: Option<Transposed<'a, T>>,
    kept: usize,
    inverse: bool,
    want_params: bool,
    /// `a` of the bounded log-scale `s = a·tanh(ŝ/a)`, or `None` for `s = ŝ`.
    bound: Option<T>,
}

impl<'a, T: Float> Block<'a, T> {
    /// The forward pass of the coupling keeping column `kept`.
    pub fn forward_pass(fwd: Mlp<'a, T>, kept: usize, inverse: bool, bound: Option<T>) -> Self {
        Block {
            fwd,
            back: None,
            feedback: None,
            kept,
            inverse,
            want_params: false,
            bound,
        }
    }

    /// The backward pass: activations from `fwd`, the points' error through `given` (the
    /// weights the backward call received, `fwd`'s values unless substituted).
    pub fn backward_pass(
        fwd: Mlp<'a, T>,
        given: Mlp<'a, T>,
        kept: usize,
        inverse: bool,
        want_params: bool,
        bound: Option<T>,
    ) -> Self {
        let same = given.w1 == fwd.w1 && given.w2 == fwd.w2 && given.w3 == fwd.w3;
        Block {
            fwd,
            back: Some(Transposed::new(&fwd)),
            feedback: (!same).then(|| Transposed::new(&given)),
            kept,
            inverse,
            want_params,
            bound,
        }
    }

    /// `y = coupling(x)` on a block `xb, yb` of `(n, 2)` points, with the build `isa`.
    pub fn forward(&self, isa: Isa, xb: &[T], yb: &mut [T], sc: &mut Scratch<T>) {
        // SAFETY (both): an `Isa` other than `Portable` exists only when the CPU has its
        // features (`Isa::detect`, `Isa::available`).
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.forward_avx512(xb, yb, sc) },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.forward_avx2(xb, yb, sc) },
            Isa::Portable => self.forward_impl::<false, 16>(xb, yb, sc),
        }
    }

    /// Adds `∂L/∂x` of the block into `gx` (if given) and writes its parameter gradients into
    /// `acc` (laid out like the parameters, if wanted), from `dy = ∂L/∂y`.
    pub fn backward(
        &self,
        isa: Isa,
        xb: &[T],
        dyb: &[T],
        gx: Option<&mut [T]>,
        acc: &mut [T],
        sc: &mut Scratch<T>,
    ) {
        // SAFETY (both): as in `forward`.
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { self.backward_avx512(xb, dyb, gx, acc, sc) },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { self.backward_avx2(xb, dyb, gx, acc, sc) },
            Isa::Portable => self.backward_impl::<false, 16, 8>(xb, dyb, gx, acc, sc),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn forward_avx2(&self, xb: &[T], yb: &mut [T], sc: &mut Scratch<T>) {
        self.forward_impl::<true, 16>(xb, yb, sc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn backward_avx2(
        &self,
        xb: &[T],
        dyb: &[T],
        gx: Option<&mut [T]>,
        acc: &mut [T],
        sc: &mut Scratch<T>,
    ) {
        self.backward_impl::<true, 16, 8>(xb, dyb, gx, acc, sc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    unsafe fn forward_avx512(&self, xb: &[T], yb: &mut [T], sc: &mut Scratch<T>) {
        self.forward_impl::<true, 64>(xb, yb, sc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    unsafe fn backward_avx512(
        &self,
        xb: &[T],
        dyb: &[T],
        gx: Option<&mut [T]>,
        acc: &mut [T],
        sc: &mut Scratch<T>,
    ) {
        self.backward_impl::<true, 64, 16>(xb, dyb, gx, acc, sc)
    }

    /// The MLP on the chunk loaded in `sc`, then the bound on its log-scales: `sc.ts` holds
    /// `[t; s]` with `s = a·tanh(ŝ/a)` when bounded. `tanh(x) = 1 − 2/(exp(2x) + 1)` through
    /// the vectorised `exp`: exactly 0 at 0, ±1 (never NaN) where `exp(2x)` under- or
    /// overflows.
    #[inline(always)]
    fn mlp<const FMA: bool, const TILE: usize>(&self, sc: &mut Scratch<T>) {
        self.fwd.forward::<FMA, TILE>(sc);
        if let Some(a) = self.bound {
            let two = T::one() + T::one();
            let s: &mut [T; CHUNK] = (&mut sc.ts[CHUNK..]).try_into().unwrap();
            let mut e = s.map(|v| two * v / a);
            exp_chunk::<T, FMA>(&mut e);
            for (v, e) in s.iter_mut().zip(e) {
                *v = a * (T::one() - two / (e + T::one()));
            }
        }
    }

    /// `∂s/∂ŝ` of a bounded log-scale `s`: `1 − (s/a)²` (1 when unbounded).
    #[inline(always)]
    fn bound_slope(&self, s: T) -> T {
        match self.bound {
            Some(a) => T::one() - (s / a) * (s / a),
            None => T::one(),
        }
    }

    /// `∂y_o/∂x_o` of the chunk: `exp(s)`, or `exp(−s)` for the inverse.
    #[inline(always)]
    fn scale<const FMA: bool>(&self, sc: &Scratch<T>) -> [T; CHUNK] {
        let mut e: [T; CHUNK] = sc.ts[CHUNK..].try_into().unwrap();
        if self.inverse {
            e.iter_mut().for_each(|v| *v = -*v);
        }
        exp_chunk::<T, FMA>(&mut e);
        e
    }

    #[inline(always)]
    pub(in crate::nn::coupling) fn forward_impl<const FMA: bool, const TILE: usize>(
        &self,
        xb: &[T],
        yb: &mut [T],
        sc: &mut Scratch<T>,
    ) {
        let (c, o) = (self.kept, 1 - self.kept);
        for (yc, xc) in yb.chunks_mut(2 * CHUNK).zip(xb.chunks(2 * CHUNK)) {
            sc.load(xc, c);
            self.mlp::<FMA, TILE>(sc);
            let e = self.scale::<FMA>(sc);
            let t = &sc.ts[..CHUNK];
            for (p, (y, x)) in yc.chunks_exact_mut(2).zip(xc.chunks_exact(2)).enumerate() {
                y[c] = x[c];
                y[o] = if self.inverse {
                    (x[o] - t[p]) * e[p]
                } else {
                    madd::<T, FMA>(x[o], e[p], t[p])
                };
            }
        }
    }

    #[inline(always)]
    pub(in crate::nn::coupling) fn backward_impl<
        const FMA: bool,
        const TILE: usize,
        const LANES: usize,
    >(
        &self,
        xb: &[T],
        dyb: &[T],
        mut gx: Option<&mut [T]>,
        acc: &mut [T],
        sc: &mut Scratch<T>,
    ) {
        let (c, o, zero) = (self.kept, 1 - self.kept, T::zero());
        let back = self
            .back
            .as_ref()
            .expect("coupling: backward of a forward block");
        if self.want_params {
            sc.lanes[..acc.len() * LANES].fill(zero);
        }
        let chunks = xb.chunks(2 * CHUNK).zip(dyb.chunks(2 * CHUNK));
        for (ci, (xc, dyc)) in chunks.enumerate() {
            let (mut xo, mut go) = ([zero; CHUNK], [zero; CHUNK]);
            for (p, (x, d)) in xc.chunks_exact(2).zip(dyc.chunks_exact(2)).enumerate() {
                (xo[p], go[p]) = (x[o], d[o]);
            }
            sc.load(xc, c);
            self.mlp::<FMA, TILE>(sc);
            // e = ∂y_o/∂x_o; padding points have go = 0 and contribute nothing. A zero error
            // gives zero whatever e is (no 0·∞ where an unbounded scale overflowed).
            let e = self.scale::<FMA>(sc);
            let (t, s) = sc.ts.split_at(CHUNK);
            let (gt, gs) = sc.g3.split_at_mut(CHUNK);
            for p in 0..CHUNK {
                let ge = if go[p] == zero { zero } else { go[p] * e[p] };
                let slope = self.bound_slope(s[p]);
                if self.inverse {
                    gt[p] = -ge;
                    gs[p] = if ge == zero {
                        zero
                    } else {
                        -ge * (xo[p] - t[p]) * slope
                    };
                } else {
                    gt[p] = go[p];
                    gs[p] = ge * xo[p] * slope;
                }
            }
            if self.want_params || self.feedback.is_none() {
                back.backward::<FMA, TILE>(sc);
                if self.want_params {
                    sc.accumulate::<FMA, LANES>(self.fwd.h);
                }
            }
            if let Some(g) = gx.as_deref_mut() {
                if let Some(fb) = &self.feedback {
                    fb.backward::<FMA, TILE>(sc);
                }
                let g = &mut g[ci * 2 * CHUNK..];
                for (p, (g, d)) in g.chunks_exact_mut(2).zip(dyc.chunks_exact(2)).enumerate() {
                    g[c] += d[c] + sc.dv[p];
                    if go[p] != zero {
                        g[o] = madd::<T, FMA>(go[p], e[p], g[o]);
                    }
                }
            }
        }
        if self.want_params {
            let lanes = &sc.lanes[..acc.len() * LANES];
            for (a, l) in acc.iter_mut().zip(lanes.chunks_exact(LANES)) {
                *a = l.iter().fold(zero, |s, &v| s + v);
            }
        }
    }
}
