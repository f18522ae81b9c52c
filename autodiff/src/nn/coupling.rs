//! One RealNVP affine coupling (authors' code, docs/references.md#p-bucket) as a single fused tape op.
//!
//! Inputs, in order: points `x (P, 2)`, then the coupling MLP `w1 (1, H)`, `b1 (H,)`,
//! `w2 (H, H)`, `b2 (H,)`, `w3 (H, 2)`, `b3 (2,)` (weights `(in, out)`, `x @ W` convention).
//! Output `(P, 2)`. With `c` the kept (conditioning) column and `o = 1 − c`:
//! - `(t, ŝ) = MLP(x_c)`: `h1 = relu(x_c·w1 + b1)`, `h2 = relu(h1·w2 + b2)`,
//!   `(t, ŝ) = h2·w3 + b3` (last-layer column 0 is the shift, column 1 the raw log-scale);
//! - the log-scale `s = ŝ` (the authors' code, unbounded), or with a bound `a`,
//!   `s = a·tanh(ŝ/a)`: the same map near `ŝ = 0` (slope 1, so an identity-initialised flow
//!   starts the same), and `exp(±s) ∈ [e^(−a), e^a]` always, so neither the map nor its
//!   inverse can overflow (a `tanh`-scaled log-scale, common in RealNVP implementations;
//!   Glow, Kingma & Dhariwal 2018, bounds its scale with a sigmoid to the same end);
//! - forward: `y_c = x_c`, `y_o = x_o·exp(s) + t`;
//! - inverse: `y_c = x_c`, `y_o = (x_o − t)·exp(−s)`, exact for the same parameters.
//!
//! Backward, with `g = ∂L/∂y`: forward `∂L/∂t = g_o`, `∂L/∂s = g_o·x_o·exp(s)`,
//! `∂L/∂x_o = g_o·exp(s)`; inverse `∂L/∂t = −g_o·exp(−s)`, `∂L/∂s = −g_o·y_o`,
//! `∂L/∂x_o = g_o·exp(−s)`; `∂L/∂ŝ = ∂L/∂s·(1 − (s/a)²)` when bounded. A point whose error
//! `g_o` is zero contributes exactly zero, even where an unbounded `exp(±s)` overflowed (no
//! `0·∞`). Then through the MLP (ReLU derivative `[h > 0]`, 0 at the kink)
//! to its parameters and to `x_c`: `∂L/∂x_c = g_c + ∂L/∂(MLP input)`.
//!
//! Evaluation (kernels in `coupling/`): points in chunks of [`CHUNK`], a chunk's hidden
//! activations laid out `(H, CHUNK)` so every inner loop runs over points; blocks of [`BLOCK`]
//! points are rayon tasks with scratch reused across their chunks. Backward recomputes the MLP
//! per chunk (nothing is saved but a copy of the parameters, 338 at the official width).
//! Parameter gradients are summed per block and the blocks' partial sums added in block order,
//! so results do not depend on the thread count. The same code is compiled for AVX-512F, for
//! AVX2 + FMA and for the baseline target, chosen at run time; in the first two, f32 `exp` is
//! a vectorised polynomial (within 2 ulp) instead of libm's. Builds differ in rounding only.
//!
//! Feedback alignment: [`Op::weight_inputs`] is `[1, 3, 5]` (`w1, w2, w3`). Under a rule that
//! substitutes feedback matrices `B` for them in backward, the coupling acts as one layer:
//! its parameters get their exact gradient for the error `g` arriving at its output (the
//! activations and the chain to the parameters use the forward weights saved by `forward`),
//! and the error it sends back to its input points travels through the substituted weights,
//! `∂L/∂x_c = g_c + (((∂L/∂(t, s))·B3ᵀ ⊙ [h2 > 0])·B2ᵀ ⊙ [h1 > 0])·B1ᵀ`. (Per-layer feedback
//! inside the MLP would need `B` while the weight gradients are computed, which the rule's
//! two-call protocol does not provide.)

mod kernel;
mod tiles;
#[cfg(target_arch = "x86_64")]
mod x86;

pub use kernel::{BLOCK, CHUNK};

use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use kernel::{num_params, Block, Isa, Mlp, Scratch};
use rayon::prelude::*;

/// Names of the ops in this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["affine_coupling"];

/// The fused coupling `y = coupling(x; w1, b1, w2, b2, w3, b3)`; see the module docs.
pub struct AffineCoupling<T> {
    kept: usize,
    inverse: bool,
    /// `a` of the bounded log-scale `s = a·tanh(ŝ/a)`, or `None` (unbounded).
    log_scale_bound: Option<T>,
    /// The kernel build (the fastest this CPU runs).
    isa: Isa,
    /// The parameters `forward` saw (inputs 1..=6 concatenated), for backward.
    params: Vec<T>,
}

impl<T: Float> AffineCoupling<T> {
    /// The coupling that keeps column `kept` (0 or 1) and transforms the other one; `inverse`
    /// selects `y_o = (x_o − t)·exp(−s)` instead of `x_o·exp(s) + t`.
    #[track_caller]
    pub fn new(kept: usize, inverse: bool) -> Self {
        assert!(
            kept < 2,
            "affine_coupling: kept column {kept} is not 0 or 1"
        );
        AffineCoupling {
            kept,
            inverse,
            log_scale_bound: None,
            isa: Isa::detect(),
            params: Vec::new(),
        }
    }

    /// The same coupling with its log-scale bounded: `s = a·tanh(ŝ/a)` for `Some(a)` (module
    /// docs), unbounded for `None`. Panics unless `a` is finite and positive.
    #[track_caller]
    pub fn with_log_scale_bound(mut self, bound: Option<f64>) -> Self {
        if let Some(a) = bound {
            assert!(
                a.is_finite() && a > 0.0,
                "affine_coupling: log-scale bound {a} must be finite and > 0"
            );
        }
        self.log_scale_bound = bound.map(T::of);
        self
    }

    /// The coupling run by a given kernel build (tests compare the builds).
    #[cfg(test)]
    fn with_isa(kept: usize, inverse: bool, isa: Isa) -> Self {
        AffineCoupling {
            isa,
            ..Self::new(kept, inverse)
        }
    }
}

/// The hidden width `H`, after checking every input shape against it.
#[track_caller]
fn hidden<T: Float>(inputs: &[&Tensor<T>]) -> usize {
    assert_eq!(
        inputs.len(),
        7,
        "affine_coupling: takes points and 6 MLP parameters, got {} inputs",
        inputs.len()
    );
    let x = inputs[0].shape();
    assert!(
        x.rank() == 2 && x.dim(1) == 2,
        "affine_coupling: expected points (P, 2), got {x:?}"
    );
    let w1 = inputs[1].shape();
    assert!(
        w1.rank() == 2 && w1.dim(0) == 1,
        "affine_coupling: w1 {w1:?} is not (1, H)"
    );
    let h = w1.dim(1);
    let want: [&[usize]; 5] = [&[h], &[h, h], &[h], &[h, 2], &[2]];
    for (i, (name, dims)) in ["b1", "w2", "b2", "w3", "b3"].iter().zip(want).enumerate() {
        let got = inputs[i + 2].shape();
        assert!(
            got.dims() == dims,
            "affine_coupling: {name} {got:?} does not match w1 {w1:?} (want {:?})",
            Shape::new(dims)
        );
    }
    h
}

impl<T: Float> Op<T> for AffineCoupling<T> {
    fn name(&self) -> &'static str {
        "affine_coupling"
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        hidden(inputs);
        inputs[0].shape()
    }

    fn overwrites_output(&self) -> bool {
        true
    }

    fn weight_inputs(&self) -> &'static [usize] {
        &[1, 3, 5]
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let h = hidden(inputs);
        self.params.clear();
        for t in &inputs[1..] {
            self.params.extend_from_slice(t.data());
        }
        let block = Block::forward_pass(
            Mlp::from_flat(&self.params, h),
            self.kept,
            self.inverse,
            self.log_scale_bound,
        );
        out.data_mut()
            .par_chunks_mut(2 * BLOCK)
            .zip(inputs[0].data().par_chunks(2 * BLOCK))
            .for_each_init(
                || Scratch::forward(h),
                |sc, (yb, xb)| block.forward(self.isa, xb, yb, sc),
            );
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let h = hidden(cx.inputs);
        let want_params = (1..7).any(|i| dx.wants(i));
        if !want_params && !dx.wants(0) {
            return;
        }
        let given = Mlp::from_parts(h, std::array::from_fn(|i| cx.inputs[i + 1].data()));
        let fwd = Mlp::from_flat(&self.params, h);
        let block = Block::backward_pass(
            fwd,
            given,
            self.kept,
            self.inverse,
            want_params,
            self.log_scale_bound,
        );
        let (x, dy) = (cx.inputs[0].data(), cx.dy.data());
        let (nblocks, np) = ((x.len() / 2).div_ceil(BLOCK), num_params(h));
        let mut partial = dx.scratch([nblocks, np]);
        {
            let gx: Vec<Option<&mut [T]>> = match dx.slot_data(0) {
                Some(g) => g.chunks_mut(2 * BLOCK).map(Some).collect(),
                None => (0..nblocks).map(|_| None).collect(),
            };
            partial
                .data_mut()
                .par_chunks_mut(np)
                .zip(x.par_chunks(2 * BLOCK))
                .zip(dy.par_chunks(2 * BLOCK))
                .zip(gx)
                .for_each_init(
                    || Scratch::backward(h, want_params),
                    |sc, (((acc, xb), dyb), gxb)| block.backward(self.isa, xb, dyb, gxb, acc, sc),
                );
        }
        // Parameter gradients: the blocks' partial sums, in block order.
        let mut offset = 0;
        for (i, t) in cx.inputs[1..].iter().enumerate() {
            let len = t.numel();
            if let Some(g) = dx.slot_data(i + 1) {
                for part in partial.data().chunks_exact(np) {
                    for (a, &b) in g.iter_mut().zip(&part[offset..offset + len]) {
                        *a += b;
                    }
                }
            }
            offset += len;
        }
        dx.recycle(partial);
    }
}

impl<T: Float> Tape<T> {
    /// One affine coupling of the points `(P, 2)`, keeping column `kept` (0 or 1) and
    /// transforming the other; `mlp = [w1, b1, w2, b2, w3, b3]`; `log_scale_bound` as in
    /// [`AffineCoupling::with_log_scale_bound`]. See [`crate::nn::coupling`].
    #[track_caller]
    pub fn affine_coupling(
        &mut self,
        points: Var,
        mlp: &[Var],
        kept: usize,
        inverse: bool,
        log_scale_bound: Option<f64>,
    ) -> Var {
        assert_eq!(
            mlp.len(),
            6,
            "affine_coupling: {} MLP parameters, want w1, b1, w2, b2, w3, b3",
            mlp.len()
        );
        let mut inputs = [points; 7];
        inputs[1..].copy_from_slice(mlp);
        self.apply(
            AffineCoupling::new(kept, inverse).with_log_scale_bound(log_scale_bound),
            &inputs,
        )
    }
}

#[cfg(test)]
mod tests;
