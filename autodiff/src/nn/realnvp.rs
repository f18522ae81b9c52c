//! RealNVP flow on 2-D points: the cell-position map P of the cortex (authors' code, docs/references.md#p-bucket).
//!
//! `XY = P(UV)`: an ONS pixel's coordinates `uv ∈ [−1, 1]²` go to the position `xy` the cortex
//! believes that cone has in visual space; [`RealNvp::inverse`] is `UV = P⁻¹(XY)`, exact.
//!
//! Architecture (official: `normflows` with 8 `AffineCouplingBlock`s, each followed by
//! `Permute(2, "swap")`):
//! - Points are `(N, 2)`, columns `(x, y)`.
//! - Block `k` keeps coordinate `c = k mod 2` and transforms the other one, `o = 1 − c`:
//!   `(t, s) = MLP_k(p_c)`, `p_o ← p_o · exp(s) + t` (output 0 is the shift, output 1 the
//!   log-scale). Alternating `c` is the official swap after every block without moving data;
//!   with an even number of blocks the output order is `(x, y)` as in the official code.
//! - `MLP_k`: Linear 1→16, ReLU, Linear 16→16, ReLU, Linear 16→2. Hidden layers are initialised
//!   like PyTorch's `nn.Linear` (weight and bias uniform in `±1/√fan_in`); the last layer is
//!   zero, so `t = s = 0` and the flow starts as the identity. 8 blocks × 338 = 2 704
//!   parameters, as the official model.
//! - Log-scale: `s = ŝ`, the MLP's raw output (official), or, with
//!   [`RealNvpConfig::log_scale_bound`] `= Some(a)`, `s = a·tanh(ŝ/a)`, so that every block
//!   scales by a factor in `[e^(−a), e^a]` and neither P nor P⁻¹ can overflow
//!   ([`crate::nn::coupling`]).
//! - Inverse: blocks in reverse order, `p_o ← (p_o − t) · exp(−s)`; `t, s` depend only on the
//!   untouched `p_c`, so the inverse is exact (up to rounding) for any parameters.
//! - `log |det ∂P/∂uv| = Σ_k s_k`: the Jacobian of each block is triangular with diagonal
//!   `(1, exp(s_k))`.
//!
//! Parameters live in a [`ParamStore`] as `{prefix}.block{k}.fc{1,2,3}.{weight,bias}`. Weights
//! are `(in, out)` (the crate's `x @ W` convention; PyTorch stores the transpose).
//!
//! Two evaluation paths: on a tape ([`RealNvp::forward`], [`RealNvp::inverse`], differentiable
//! in points and parameters; each block is one fused [`affine_coupling`](crate::nn::coupling)
//! op) and plain f64 without a tape ([`RealNvp::forward_points`], [`RealNvp::inverse_points`],
//! [`RealNvp::log_det_jacobian`]) for evaluation and tests.

use crate::{Float, ParamId, ParamStore, Tape, Tensor, Var};
use rand::Rng;
use rayon::prelude::*;

/// Shape of the flow. The official values are the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RealNvpConfig {
    /// Number of affine coupling blocks (authors' code, docs/references.md#p-bucket: 8).
    pub blocks: usize,
    /// Width of the two hidden layers of each coupling MLP (authors' code, docs/references.md#p-bucket: 16).
    pub hidden: usize,
    /// `a` of the bounded log-scale `s = a·tanh(ŝ/a)`; `None`: unbounded, as the authors' code.
    pub log_scale_bound: Option<f64>,
}

impl Default for RealNvpConfig {
    fn default() -> Self {
        RealNvpConfig {
            blocks: 8,
            hidden: 16,
            log_scale_bound: None,
        }
    }
}

/// Parameters of one coupling MLP, in the order `w1, b1, w2, b2, w3, b3`.
const PER_BLOCK: usize = 6;

/// A RealNVP flow; holds parameter ids, the values live in a [`ParamStore`].
#[derive(Clone, Debug)]
pub struct RealNvp {
    cfg: RealNvpConfig,
    /// `PER_BLOCK` ids per block.
    ids: Vec<ParamId>,
}

/// The flow's parameters recorded on a tape (`w1, b1, w2, b2, w3, b3` per block), so that a
/// forward and an inverse in the same step share one copy. Build with [`RealNvp::record`] or,
/// from leaves of your own (gradient checks), with [`RealNvpVars::new`].
#[derive(Clone, Debug)]
pub struct RealNvpVars(Vec<Var>);

impl RealNvpVars {
    /// Wraps parameter vars in store order (6 per block).
    #[track_caller]
    pub fn new(vars: Vec<Var>) -> Self {
        assert!(
            vars.len().is_multiple_of(PER_BLOCK),
            "RealNvpVars: {} vars is not 6 per block",
            vars.len()
        );
        RealNvpVars(vars)
    }
}

impl RealNvp {
    /// Adds the parameters under `prefix` to `store` (hidden layers PyTorch-default random,
    /// last layers zero: the identity map).
    pub fn new<T: Float>(
        store: &mut ParamStore<T>,
        prefix: &str,
        cfg: RealNvpConfig,
        rng: &mut impl Rng,
    ) -> Self {
        let h = cfg.hidden;
        let mut ids = Vec::with_capacity(cfg.blocks * PER_BLOCK);
        let mut uniform = |shape: &[usize], fan_in: usize| {
            let bound = 1.0 / (fan_in as f64).sqrt();
            Tensor::from_fn(shape, |_| T::of(rng.random_range(-bound..bound)))
        };
        for k in 0..cfg.blocks {
            let name = |layer: usize, what: &str| format!("{prefix}.block{k}.fc{layer}.{what}");
            ids.push(store.add(name(1, "weight"), uniform(&[1, h], 1)));
            ids.push(store.add(name(1, "bias"), uniform(&[h], 1)));
            ids.push(store.add(name(2, "weight"), uniform(&[h, h], h)));
            ids.push(store.add(name(2, "bias"), uniform(&[h], h)));
            ids.push(store.add(name(3, "weight"), Tensor::zeros([h, 2])));
            ids.push(store.add(name(3, "bias"), Tensor::zeros([2])));
        }
        RealNvp { cfg, ids }
    }

    /// The configuration.
    pub fn config(&self) -> RealNvpConfig {
        self.cfg
    }

    /// Parameter ids in store order (6 per block: `w1, b1, w2, b2, w3, b3`).
    pub fn param_ids(&self) -> &[ParamId] {
        &self.ids
    }

    /// Number of scalar parameters (`blocks · (h² + 5h + 2)`; 2 704 for the defaults).
    pub fn num_params(&self) -> usize {
        let h = self.cfg.hidden;
        self.cfg.blocks * (h * h + 5 * h + 2)
    }

    /// Records the parameters on `tape` once, for [`RealNvp::forward_with`] / `inverse_with`.
    pub fn record<T: Float>(&self, tape: &mut Tape<T>, store: &ParamStore<T>) -> RealNvpVars {
        RealNvpVars(self.ids.iter().map(|&id| store.var(tape, id)).collect())
    }

    /// `P(points)`: `(N, 2)` → `(N, 2)` on the tape.
    pub fn forward<T: Float>(&self, tape: &mut Tape<T>, store: &ParamStore<T>, points: Var) -> Var {
        let vars = self.record(tape, store);
        self.forward_with(tape, &vars, points)
    }

    /// `P⁻¹(points)`: `(N, 2)` → `(N, 2)` on the tape, the exact inverse of `forward`.
    pub fn inverse<T: Float>(&self, tape: &mut Tape<T>, store: &ParamStore<T>, points: Var) -> Var {
        let vars = self.record(tape, store);
        self.inverse_with(tape, &vars, points)
    }

    /// `P(points)` with already recorded parameters.
    #[track_caller]
    pub fn forward_with<T: Float>(
        &self,
        tape: &mut Tape<T>,
        vars: &RealNvpVars,
        points: Var,
    ) -> Var {
        self.check(tape, vars, points);
        self.couplings(tape, vars, points, false)
    }

    /// `P⁻¹(points)` with already recorded parameters.
    #[track_caller]
    pub fn inverse_with<T: Float>(
        &self,
        tape: &mut Tape<T>,
        vars: &RealNvpVars,
        points: Var,
    ) -> Var {
        self.check(tape, vars, points);
        self.couplings(tape, vars, points, true)
    }

    #[track_caller]
    fn check<T: Float>(&self, tape: &Tape<T>, vars: &RealNvpVars, points: Var) {
        let s = tape.shape(points);
        assert!(
            s.rank() == 2 && s.dim(1) == 2,
            "realnvp: expected points (N, 2), got {s:?}"
        );
        assert_eq!(
            vars.0.len(),
            self.ids.len(),
            "realnvp: {} parameter vars for a flow of {} blocks",
            vars.0.len(),
            self.cfg.blocks
        );
    }

    /// The blocks in order, or in reverse order each inverted: block `k` is one fused
    /// [`affine_coupling`](crate::nn::coupling) op keeping column `k mod 2`.
    fn couplings<T: Float>(
        &self,
        tape: &mut Tape<T>,
        vars: &RealNvpVars,
        points: Var,
        inverse: bool,
    ) -> Var {
        let nb = self.cfg.blocks;
        (0..nb).fold(points, |p, j| {
            let k = if inverse { nb - 1 - j } else { j };
            let mlp = &vars.0[k * PER_BLOCK..][..PER_BLOCK];
            tape.affine_coupling(p, mlp, k % 2, inverse, self.cfg.log_scale_bound)
        })
    }

    /// `P(points)` in plain f64, `(N, 2)` → `(N, 2)`, in parallel over points.
    pub fn forward_points<T: Float>(
        &self,
        store: &ParamStore<T>,
        points: &Tensor<f64>,
    ) -> Tensor<f64> {
        self.map_points(store, points, false).0
    }

    /// `P⁻¹(points)` in plain f64.
    pub fn inverse_points<T: Float>(
        &self,
        store: &ParamStore<T>,
        points: &Tensor<f64>,
    ) -> Tensor<f64> {
        self.map_points(store, points, true).0
    }

    /// `log |det ∂P/∂uv|` at each of the `(N, 2)` points: `(N,)`, the sum of the blocks'
    /// log-scales.
    pub fn log_det_jacobian<T: Float>(
        &self,
        store: &ParamStore<T>,
        points: &Tensor<f64>,
    ) -> Tensor<f64> {
        self.map_points(store, points, false).1
    }

    /// Mapped points and `Σ_k s_k` along the way (the forward log-determinant when
    /// `inverse == false`).
    #[track_caller]
    fn map_points<T: Float>(
        &self,
        store: &ParamStore<T>,
        points: &Tensor<f64>,
        inverse: bool,
    ) -> (Tensor<f64>, Tensor<f64>) {
        let s = points.shape();
        assert!(
            s.rank() == 2 && s.dim(1) == 2,
            "realnvp: expected points (N, 2), got {s:?}"
        );
        let mlps: Vec<Mlp> = (0..self.cfg.blocks)
            .map(|k| {
                Mlp::from_store(
                    store,
                    &self.ids[k * PER_BLOCK..][..PER_BLOCK],
                    self.cfg.hidden,
                )
            })
            .collect();
        let n = s.dim(0);
        let mut out = points.clone();
        let mut logdet = Tensor::<f64>::zeros([n]);
        out.data_mut()
            .par_chunks_mut(2)
            .zip(logdet.data_mut().par_iter_mut())
            .with_min_len(256)
            .for_each(|(p, ld)| {
                let mut hidden = [0.0; 2 * MAX_HIDDEN];
                let nb = mlps.len();
                for j in 0..nb {
                    let k = if inverse { nb - 1 - j } else { j };
                    let c = k % 2;
                    let (t, s) = mlps[k].eval(p[c], &mut hidden);
                    let s = match self.cfg.log_scale_bound {
                        Some(a) => a * (s / a).tanh(),
                        None => s,
                    };
                    p[1 - c] = if inverse {
                        (p[1 - c] - t) * (-s).exp()
                    } else {
                        p[1 - c] * s.exp() + t
                    };
                    *ld += s;
                }
            });
        (out, logdet)
    }
}

/// Largest hidden width the plain-f64 path supports (stack buffers).
const MAX_HIDDEN: usize = 64;

/// One coupling MLP's parameters in f64, weights `(in, out)` row-major.
struct Mlp {
    h: usize,
    w1: Vec<f64>,
    b1: Vec<f64>,
    w2: Vec<f64>,
    b2: Vec<f64>,
    w3: Vec<f64>,
    b3: Vec<f64>,
}

impl Mlp {
    #[track_caller]
    fn from_store<T: Float>(store: &ParamStore<T>, ids: &[ParamId], h: usize) -> Self {
        assert!(
            h <= MAX_HIDDEN,
            "realnvp: plain evaluation supports hidden ≤ {MAX_HIDDEN}, got {h}"
        );
        let get = |i: usize| {
            store
                .get(ids[i])
                .data()
                .iter()
                .map(|v| v.as_f64())
                .collect::<Vec<f64>>()
        };
        Mlp {
            h,
            w1: get(0),
            b1: get(1),
            w2: get(2),
            b2: get(3),
            w3: get(4),
            b3: get(5),
        }
    }

    /// `(shift, log-scale)` for the conditioning value `v`.
    fn eval(&self, v: f64, buf: &mut [f64; 2 * MAX_HIDDEN]) -> (f64, f64) {
        let h = self.h;
        let (a, b) = buf.split_at_mut(MAX_HIDDEN);
        let (a, b) = (&mut a[..h], &mut b[..h]);
        for ((a, &w), &bias) in a.iter_mut().zip(&self.w1).zip(&self.b1) {
            *a = (v * w + bias).max(0.0);
        }
        // b = relu(a @ w2 + b2), w2 being (in, out) row-major.
        b.copy_from_slice(&self.b2);
        for (&ai, w_row) in a.iter().zip(self.w2.chunks_exact(h)) {
            for (bj, &wij) in b.iter_mut().zip(w_row) {
                *bj += ai * wij;
            }
        }
        let (mut t, mut s) = (self.b3[0], self.b3[1]);
        for (&bi, w) in b.iter().zip(self.w3.chunks_exact(2)) {
            let bi = bi.max(0.0);
            t += bi * w[0];
            s += bi * w[1];
        }
        (t, s)
    }
}

#[cfg(test)]
mod tests;
