//! The fused affine coupling on blocks of points (see [`super`] for the maths): the chunked
//! MLP forward, its backward, the parameter-gradient sums, and the choice of SIMD build.
//!
//! Layout: a chunk of [`CHUNK`] points; activations and errors are row blocks `(rows, CHUNK)`,
//! so every inner loop runs over points and vectorises. Each layer is one [`rows`] product
//! with its weights stored `(in, out)` row-major (backward uses transposed copies,
//! [`Transposed`]). Parameter gradients are [`outer`] products of row blocks, kept as `LANES`
//! independent partial sums per parameter (vector registers, no reassociation needed) and
//! reduced once per block, in a fixed order. A trailing row of ones in the input blocks makes
//! each bias gradient the last row of its weight gradient, which is exactly the parameter
//! layout `w, b`.
//!
//! Builds ([`Isa`]): the same generic code compiled for AVX-512F, for AVX2 + FMA (both x86-64,
//! chosen at run time) and for the compilation target without fused multiply-adds; tile sizes
//! follow the vector registers. They differ in rounding only (test `kernel_builds_agree`).

use super::tiles::{mask, outer, relu, rows};
use crate::Float;

mod block;

pub(super) use block::Block;

/// Points per chunk: the length of every row (a multiple of every build's `TILE`, `LANES`).
pub const CHUNK: usize = 64;
/// Points per parallel task and per partial sum of the parameter gradients.
pub const BLOCK: usize = 1024;
/// Most partial sums per parameter gradient (`LANES` of a build).
const MAX_LANES: usize = 16;

/// One MLP's parameters as flat slices, in input order (`w1, b1, w2, b2, w3, b3`), weights
/// `(in, out)` row-major.
#[derive(Clone, Copy)]
pub(super) struct Mlp<'a, T> {
    pub h: usize,
    pub w1: &'a [T],
    pub b1: &'a [T],
    pub w2: &'a [T],
    pub b2: &'a [T],
    pub w3: &'a [T],
    pub b3: &'a [T],
}

/// Number of parameters of an MLP of hidden width `h`: `h² + 5h + 2`.
pub(super) fn num_params(h: usize) -> usize {
    h * h + 5 * h + 2
}

/// Offsets of `w1, b1, w2, b2, w3, b3` in a buffer laid out like the parameters, and its end.
fn offsets(h: usize) -> [usize; 7] {
    let len = [h, h, h * h, h, 2 * h, 2];
    let mut o = [0; 7];
    for i in 0..6 {
        o[i + 1] = o[i] + len[i];
    }
    o
}

impl<'a, T: Float> Mlp<'a, T> {
    /// The MLP of hidden width `h` stored contiguously in `buf` (`num_params(h)` values).
    pub fn from_flat(buf: &'a [T], h: usize) -> Self {
        let o = offsets(h);
        let p = |i: usize| &buf[o[i]..o[i + 1]];
        Mlp::from_parts(h, [p(0), p(1), p(2), p(3), p(4), p(5)])
    }

    /// The MLP from its six parameter slices.
    pub fn from_parts(h: usize, p: [&'a [T]; 6]) -> Self {
        let [w1, b1, w2, b2, w3, b3] = p;
        Mlp {
            h,
            w1,
            b1,
            w2,
            b2,
            w3,
            b3,
        }
    }

    /// `h1, h2` (after ReLU) and `ts = [t; s]` from the conditioning values in row 0 of `v1`.
    #[inline(always)]
    fn forward<const FMA: bool, const TILE: usize>(&self, sc: &mut Scratch<T>) {
        let hh = self.h * CHUNK;
        rows::<T, FMA, TILE>(self.w1, Some(self.b1), &sc.v1[..CHUNK], &mut sc.h1[..hh]);
        relu(&mut sc.h1[..hh]);
        rows::<T, FMA, TILE>(self.w2, Some(self.b2), &sc.h1[..hh], &mut sc.h2[..hh]);
        relu(&mut sc.h2[..hh]);
        rows::<T, FMA, TILE>(self.w3, Some(self.b3), &sc.h2[..hh], &mut sc.ts);
    }
}

/// The weights errors flow back through: `w3ᵀ (2, H)`, `w2ᵀ (H, H)` and `w1` (as stored,
/// `(1, H)`, is `w1ᵀ (H, 1)` read row-major).
pub(super) struct Transposed<'a, T> {
    w1: &'a [T],
    w2t: Vec<T>,
    w3t: Vec<T>,
}

impl<'a, T: Float> Transposed<'a, T> {
    pub fn new(m: &Mlp<'a, T>) -> Self {
        let h = m.h;
        Transposed {
            w1: m.w1,
            w2t: (0..h * h).map(|i| m.w2[(i % h) * h + i / h]).collect(),
            w3t: (0..2 * h).map(|i| m.w3[(i % h) * 2 + i / h]).collect(),
        }
    }

    /// From `g3 = [∂L/∂t; ∂L/∂s]`: the hidden errors `gh2, gh1` (masked by the ReLUs of
    /// `h2, h1`) and the error at the MLP input, `dv`.
    #[inline(always)]
    fn backward<const FMA: bool, const TILE: usize>(&self, sc: &mut Scratch<T>) {
        let hh = self.w1.len() * CHUNK;
        rows::<T, FMA, TILE>(&self.w3t, None, &sc.g3, &mut sc.gh2);
        mask(&mut sc.gh2, &sc.h2[..hh]);
        rows::<T, FMA, TILE>(&self.w2t, None, &sc.gh2, &mut sc.gh1);
        mask(&mut sc.gh1, &sc.h1[..hh]);
        rows::<T, FMA, TILE>(self.w1, None, &sc.gh1, &mut sc.dv);
    }
}

/// Per-task buffers, reused across the chunks and blocks of one rayon job.
pub(super) struct Scratch<T> {
    /// `[v; 1]`: the conditioning values.
    v1: Vec<T>,
    /// `[h1; 1]`, `[h2; 1]`: the hidden activations after ReLU, `(H + 1, CHUNK)`.
    h1: Vec<T>,
    h2: Vec<T>,
    /// `[t; s]`.
    ts: Vec<T>,
    /// `[∂L/∂t; ∂L/∂s]`.
    g3: Vec<T>,
    /// The errors at the pre-activations of `h1, h2`, `(H, CHUNK)`.
    gh1: Vec<T>,
    gh2: Vec<T>,
    /// `∂L/∂v` through the MLP.
    dv: Vec<T>,
    /// `LANES` partial sums per parameter gradient, laid out like the parameters.
    lanes: Vec<T>,
}

impl<T: Float> Scratch<T> {
    /// A forward pass's buffers: the activations only.
    pub fn forward(h: usize) -> Self {
        Self::new(h, false, false)
    }

    /// A backward pass's buffers: the activations, the errors and, when the parameters'
    /// gradients are wanted, their lane sums (`MAX_LANES` × one coupling's parameters: at the
    /// top of `H`'s range a gigabyte per task, so never made for a forward pass).
    pub fn backward(h: usize, want_params: bool) -> Self {
        Self::new(h, true, want_params)
    }

    fn new(h: usize, errors: bool, lanes: bool) -> Self {
        let rows = |n: usize| vec![T::zero(); n * CHUNK];
        let with_ones = |n: usize| {
            let mut b = rows(n + 1);
            b[n * CHUNK..].fill(T::one());
            b
        };
        let errors_of = |n: usize| if errors { rows(n) } else { Vec::new() };
        Scratch {
            v1: with_ones(1),
            h1: with_ones(h),
            h2: with_ones(h),
            ts: rows(2),
            g3: errors_of(2),
            gh1: errors_of(h),
            gh2: errors_of(h),
            dv: errors_of(1),
            lanes: match lanes {
                true => vec![T::zero(); num_params(h) * MAX_LANES],
                false => Vec::new(),
            },
        }
    }

    /// Row 0 of `v1` ← column `c` of the `(n, 2)` points `xc` (zero past `n`).
    #[inline(always)]
    fn load(&mut self, xc: &[T], c: usize) {
        let v = &mut self.v1[..CHUNK];
        v.fill(T::zero());
        for (v, x) in v.iter_mut().zip(xc.chunks_exact(2)) {
            *v = x[c];
        }
    }

    /// Adds this chunk's parameter gradients into the lane sums: `[w1; b1] += [v; 1]·gh1ᵀ`,
    /// `[w2; b2] += [h1; 1]·gh2ᵀ`, `[w3; b3] += [h2; 1]·[∂L/∂t; ∂L/∂s]ᵀ`.
    #[inline(always)]
    fn accumulate<const FMA: bool, const LANES: usize>(&mut self, h: usize) {
        let o = offsets(h).map(|i| i * LANES);
        outer::<T, FMA, LANES>(&mut self.lanes[o[0]..o[2]], &self.v1, &self.gh1);
        outer::<T, FMA, LANES>(&mut self.lanes[o[2]..o[4]], &self.h1, &self.gh2);
        outer::<T, FMA, LANES>(&mut self.lanes[o[4]..o[6]], &self.h2, &self.g3);
    }
}

/// The instruction set a build of the kernels is compiled for: register tiles of 4 rows ×
/// `TILE` points and `LANES` partial sums are sized to its vector registers (16 × 512 bit
/// or 16 × 256 bit for f32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Isa {
    /// AVX-512F (+ FMA): `TILE = 64`, `LANES = 16`.
    #[cfg(target_arch = "x86_64")]
    Avx512,
    /// AVX2 + FMA: `TILE = 16`, `LANES = 8`.
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// Whatever the compilation target provides, no fused multiply-add.
    Portable,
}

impl Isa {
    /// The fastest build this CPU runs.
    pub fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
            if avx2 && is_x86_feature_detected!("avx512f") {
                return Isa::Avx512;
            }
            if avx2 {
                return Isa::Avx2;
            }
        }
        Isa::Portable
    }

    /// Every build this CPU runs, fastest first.
    #[cfg(test)]
    pub fn available() -> Vec<Isa> {
        let all = [
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2,
            Isa::Portable,
        ];
        let fastest = all.iter().position(|&i| i == Isa::detect()).unwrap();
        all[fastest..].to_vec()
    }
}
