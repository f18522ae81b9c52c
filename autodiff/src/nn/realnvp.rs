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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RealNvpConfig {
    /// Number of affine coupling blocks (authors' code, docs/references.md#p-bucket: 8).
    pub blocks: usize,
    /// Width of the two hidden layers of each coupling MLP (authors' code, docs/references.md#p-bucket: 16).
    pub hidden: usize,
}

impl Default for RealNvpConfig {
    fn default() -> Self {
        RealNvpConfig {
            blocks: 8,
            hidden: 16,
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
            tape.affine_coupling(p, mlp, k % 2, inverse)
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
mod tests {
    use super::*;
    use crate::check::{check_gradients, strategies, CheckConfig};
    use proptest::prelude::*;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// A flow away from the identity: PyTorch-default hidden layers and last layers drawn
    /// with std 0.1, so each block shifts and scales by roughly ±20 % (a learned-looking map;
    /// much larger weights compound over 8 blocks into `exp(50)` scales).
    fn random_flow(seed: u64, cfg: RealNvpConfig) -> (ParamStore<f64>, RealNvp) {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut store = ParamStore::new();
        let flow = RealNvp::new(&mut store, "p", cfg, &mut rng);
        let normal = Normal::new(0.0, 0.1).unwrap();
        for ids in flow.param_ids().chunks(PER_BLOCK) {
            for &id in &ids[4..] {
                store
                    .get_mut(id)
                    .data_mut()
                    .iter_mut()
                    .for_each(|v| *v = normal.sample(&mut rng));
            }
        }
        (store, flow)
    }

    /// Block `k` (or its inverse) recorded op by op (slice, linear, relu, exp, mul, add,
    /// concat): the implementation before the fused op, kept as the reference.
    fn coupling_op_by_op(tape: &mut Tape<f64>, w: &[Var], p: Var, k: usize, inverse: bool) -> Var {
        let c = k % 2;
        let kept = tape.slice(p, c, 1);
        let moved = tape.slice(p, 1 - c, 1);
        let h1 = tape.linear(kept, w[0], w[1]);
        let h1 = tape.relu(h1);
        let h2 = tape.linear(h1, w[2], w[3]);
        let h2 = tape.relu(h2);
        let ts = tape.linear(h2, w[4], w[5]);
        let (t, s) = (tape.slice(ts, 0, 1), tape.slice(ts, 1, 1));
        let moved = if inverse {
            let shifted = tape.sub(moved, t);
            let neg = tape.neg(s);
            let inv_scale = tape.exp(neg);
            tape.mul(shifted, inv_scale)
        } else {
            let scale = tape.exp(s);
            let scaled = tape.mul(moved, scale);
            tape.add(scaled, t)
        };
        if c == 0 {
            tape.concat(&[kept, moved])
        } else {
            tape.concat(&[moved, kept])
        }
    }

    /// The flow's value at `x` and the gradients of `Σ r ⊙ flow(x)` to the points and to
    /// every parameter, through the fused ops or op by op.
    fn value_and_grads(
        flow: &RealNvp,
        store: &ParamStore<f64>,
        x: &Tensor<f64>,
        r: &Tensor<f64>,
        inverse: bool,
        fused: bool,
    ) -> Vec<Tensor<f64>> {
        let mut tape = Tape::<f64>::new();
        let vars = flow.record(&mut tape, store);
        let xv = tape.leaf(x.clone());
        let y = match (fused, inverse) {
            (true, false) => flow.forward_with(&mut tape, &vars, xv),
            (true, true) => flow.inverse_with(&mut tape, &vars, xv),
            (false, _) => {
                let nb = flow.config().blocks;
                (0..nb).fold(xv, |p, j| {
                    let k = if inverse { nb - 1 - j } else { j };
                    let w = &vars.0[k * PER_BLOCK..][..PER_BLOCK];
                    coupling_op_by_op(&mut tape, w, p, k, inverse)
                })
            }
        };
        tape.backward_from(&[(y, r.clone())], &mut crate::NoHooks);
        let mut out = vec![tape.value(y).clone(), tape.grad(xv).unwrap().clone()];
        out.extend(vars.0.iter().map(|&v| tape.grad(v).unwrap().clone()));
        out
    }

    /// The smallest |ReLU input| met while mapping `p` forward through `flow`.
    fn kink_distance(flow: &RealNvp, store: &ParamStore<f64>, mut p: [f64; 2]) -> f64 {
        let h = flow.config().hidden;
        let mut nearest = f64::INFINITY;
        for (k, ids) in flow.param_ids().chunks(PER_BLOCK).enumerate() {
            let [w1, b1, w2, b2, w3, b3] = std::array::from_fn(|i| store.get(ids[i]).data());
            let c = k % 2;
            let a1: Vec<f64> = (0..h).map(|j| p[c] * w1[j] + b1[j]).collect();
            let a2: Vec<f64> = (0..h)
                .map(|m| b2[m] + (0..h).map(|j| a1[j].max(0.0) * w2[j * h + m]).sum::<f64>())
                .collect();
            nearest = a1.iter().chain(&a2).fold(nearest, |n, a| n.min(a.abs()));
            let out =
                |o: usize| b3[o] + (0..h).map(|m| a2[m].max(0.0) * w3[2 * m + o]).sum::<f64>();
            p[1 - c] = p[1 - c] * out(1).exp() + out(0);
        }
        nearest
    }

    fn points(seed: u64, n: usize) -> Tensor<f64> {
        let mut rng = StdRng::seed_from_u64(seed);
        Tensor::from_fn([n, 2], |_| rng.random_range(-1.0..1.0))
    }

    #[test]
    fn official_size_has_2704_parameters() {
        let mut store = ParamStore::<f32>::new();
        let flow = RealNvp::new(
            &mut store,
            "cortex.p",
            RealNvpConfig::default(),
            &mut StdRng::seed_from_u64(1),
        );
        assert_eq!(store.numel(), 2704);
        assert_eq!(flow.num_params(), 2704);
        assert_eq!(store.len(), 48);
        assert!(store.find("cortex.p.block7.fc3.bias").is_some());
    }

    #[test]
    fn identity_at_initialisation() {
        let mut store = ParamStore::<f64>::new();
        let flow = RealNvp::new(
            &mut store,
            "p",
            RealNvpConfig::default(),
            &mut StdRng::seed_from_u64(2),
        );
        let x = points(3, 50);
        assert_eq!(flow.forward_points(&store, &x), x);
        assert_eq!(flow.inverse_points(&store, &x), x);
        assert!(flow
            .log_det_jacobian(&store, &x)
            .data()
            .iter()
            .all(|&v| v == 0.0));
        let mut tape = Tape::<f64>::new();
        let v = tape.constant(x.clone());
        let y = flow.forward(&mut tape, &store, v);
        assert_eq!(tape.value(y), &x);
    }

    proptest! {
        #![proptest_config(strategies::config())]

        #[test]
        fn inverse_undoes_forward_for_random_parameters(seed in any::<u64>()) {
            let (store, flow) = random_flow(seed, RealNvpConfig::default());
            let x = points(seed ^ 1, 64);
            let y = flow.forward_points(&store, &x);
            prop_assert!(y.max_abs_diff(&x) > 1e-2, "random parameters must move the points");
            prop_assert!(flow.inverse_points(&store, &y).max_abs_diff(&x) < 1e-5);
            // The same on the tape, recording the parameters once for both directions.
            let mut tape = Tape::<f64>::new();
            let vars = flow.record(&mut tape, &store);
            let v = tape.constant(x.clone());
            let fy = flow.forward_with(&mut tape, &vars, v);
            prop_assert!(tape.value(fy).max_abs_diff(&y) < 1e-12, "tape and plain forward differ");
            let back = flow.inverse_with(&mut tape, &vars, fy);
            prop_assert!(tape.value(back).max_abs_diff(&x) < 1e-5);
        }

        /// The fused tape path equals the op-by-op one (values, and the gradients to points and
        /// all 48 parameters) to 1e-10 relative, both directions, on a random flow and more
        /// points than one chunk of the fused op.
        #[test]
        fn fused_couplings_match_op_by_op(seed in any::<u64>()) {
            let (store, flow) = random_flow(seed, RealNvpConfig::default());
            let x = points(seed ^ 4, 100);
            let r = points(seed ^ 5, 100);
            for inverse in [false, true] {
                let fused = value_and_grads(&flow, &store, &x, &r, inverse, true);
                let reference = value_and_grads(&flow, &store, &x, &r, inverse, false);
                for (i, (a, b)) in fused.iter().zip(&reference).enumerate() {
                    let scale = b.data().iter().fold(1.0f64, |m, v| m.max(v.abs()));
                    prop_assert!(
                        a.max_abs_diff(b) <= 1e-10 * scale,
                        "inverse = {inverse}, output {i} (0 value, 1 points, 2.. parameters): {} vs scale {scale}",
                        a.max_abs_diff(b)
                    );
                }
            }
        }

        /// `log |det J|` against a central-difference Jacobian of `forward_points`.
        #[test]
        fn log_det_matches_finite_difference_jacobian(seed in any::<u64>()) {
            let (store, flow) = random_flow(seed, RealNvpConfig::default());
            // Central differences across a ReLU kink are wrong: keep points whose every ReLU
            // input along the flow is at least 1e-4 from 0 (100× the step).
            let kept: Vec<f64> = points(seed ^ 2, 64)
                .data()
                .chunks(2)
                .filter(|p| kink_distance(&flow, &store, [p[0], p[1]]) >= 1e-4)
                .take(8)
                .flatten()
                .copied()
                .collect();
            prop_assert_eq!(kept.len(), 16, "fewer than 8 of 64 points clear of kinks");
            let x = Tensor::from_vec([8, 2], kept);
            let ld = flow.log_det_jacobian(&store, &x);
            let h = 1e-6;
            for i in 0..8 {
                let mut jac = [[0.0; 2]; 2];
                for (a, col) in [0usize, 1].iter().zip(0..2) {
                    let shifted = |d: f64| {
                        let mut p = Tensor::from_vec([1, 2], x.data()[2 * i..2 * i + 2].to_vec());
                        p.data_mut()[*a] += d;
                        flow.forward_points(&store, &p)
                    };
                    let (plus, minus) = (shifted(h), shifted(-h));
                    for (r, row) in jac.iter_mut().enumerate() {
                        row[col] = (plus.data()[r] - minus.data()[r]) / (2.0 * h);
                    }
                }
                let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
                prop_assert!((det.abs().ln() - ld.data()[i]).abs() < 1e-6, "point {i}: fd {} vs {}", det.abs().ln(), ld.data()[i]);
            }
        }

        /// Gradients to the points and to every parameter, through both directions, on a
        /// small flow (2 blocks, hidden 3) with random parameters (ReLU kinks are hit with
        /// probability ≈ 0 at random points).
        #[test]
        fn forward_and_inverse_gradients(seed in any::<u64>()) {
            let cfg = RealNvpConfig { blocks: 2, hidden: 3 };
            let (store, flow) = random_flow(seed, cfg);
            let mut inputs = vec![points(seed ^ 3, 4)];
            inputs.extend(flow.param_ids().iter().map(|&id| store.get(id).clone()));
            for inverse in [false, true] {
                let f = |t: &mut Tape<f64>, v: &[Var]| {
                    let vars = RealNvpVars::new(v[1..].to_vec());
                    if inverse { flow.inverse_with(t, &vars, v[0]) } else { flow.forward_with(t, &vars, v[0]) }
                };
                check_gradients(f, &inputs, &CheckConfig::default())
                    .map_err(|e| TestCaseError::fail(format!("inverse = {inverse}: {e}")))?;
            }
        }
    }

    #[test]
    #[should_panic(expected = "realnvp: expected points (N, 2), got (4, 3)")]
    fn wrong_point_shape_panics() {
        let mut store = ParamStore::<f32>::new();
        let flow = RealNvp::new(
            &mut store,
            "p",
            RealNvpConfig::default(),
            &mut StdRng::seed_from_u64(0),
        );
        let mut tape = Tape::<f32>::new();
        let x = tape.constant(Tensor::zeros([4, 3]));
        flow.forward(&mut tape, &store, x);
    }
}
