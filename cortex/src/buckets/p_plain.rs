//! P without a tape: the RealNVP flow evaluated on whole batches of points in f64 through the
//! fused coupling kernel of `autodiff::nn::coupling` (what M's de-warping grid and the learned
//! estimator's sub-pixel search call, thousands of points per step).
//!
//! The maths is that of [`RealNvp::forward_points`] / [`RealNvp::inverse_points`] (8 affine
//! couplings, block `k` keeping column `k mod 2`; inverse: blocks in reverse order, each
//! inverted). The kernel evaluates a chunk of points per layer with vector instructions (and
//! fused multiply-adds where the CPU has them), so results differ from the per-point path by
//! rounding only (test `fused_matches_per_point_path`).
//!
//! Points are `[x, y]` pairs (`(N, 2)` row-major when flattened), in place. The parameters are
//! copied to f64 once, when the map is built ([`FusedFlow::new`]); point buffers are reused
//! across calls (and threads) from a small pool instead of being allocated per call.

use crate::buckets::m::PlainFlow;
use autodiff::nn::coupling::AffineCoupling;
use autodiff::nn::realnvp::RealNvp;
use autodiff::{Op, ParamStore, Tensor};
use std::sync::Mutex;

/// Parameters per coupling MLP: `w1, b1, w2, b2, w3, b3` (the order of
/// [`RealNvp::param_ids`]).
const PER_BLOCK: usize = 6;

/// The flow `P` frozen at the current parameters, in f64.
pub struct FusedFlow {
    /// Per block, its MLP's parameters in f64.
    blocks: Vec<[Tensor<f64>; PER_BLOCK]>,
    /// The flow's log-scale bound.
    log_scale_bound: Option<f64>,
    /// Spare point buffers, returned after each call.
    spare: Mutex<Vec<Vec<f64>>>,
}

impl FusedFlow {
    /// Copies the flow's current parameters out of `params` (as f64).
    pub fn new(flow: &RealNvp, params: &ParamStore<f32>) -> Self {
        let blocks = flow
            .param_ids()
            .chunks_exact(PER_BLOCK)
            .map(|ids| std::array::from_fn(|i| params.get(ids[i]).cast::<f64>()))
            .collect();
        FusedFlow {
            blocks,
            log_scale_bound: flow.config().log_scale_bound,
            spare: Mutex::new(Vec::new()),
        }
    }

    fn take(&self) -> Vec<f64> {
        self.spare
            .lock()
            .map(|mut s| s.pop())
            .ok()
            .flatten()
            .unwrap_or_default()
    }

    fn give(&self, buf: Vec<f64>) {
        if let Ok(mut s) = self.spare.lock() {
            s.push(buf);
        }
    }

    /// `P` (or `P⁻¹` when `inverse`) of `pts`, in place.
    fn map(&self, pts: &mut [[f64; 2]], inverse: bool) {
        if pts.is_empty() || self.blocks.is_empty() {
            return;
        }
        let n = pts.len();
        let mut a = self.take();
        a.clear();
        a.extend_from_slice(pts.as_flattened());
        let mut b = self.take();
        b.resize(2 * n, 0.0);
        let mut x = Tensor::from_vec([n, 2], a);
        let mut y = Tensor::from_vec([n, 2], b);
        let nb = self.blocks.len();
        for j in 0..nb {
            let k = if inverse { nb - 1 - j } else { j };
            let p = &self.blocks[k];
            let inputs = [&x, &p[0], &p[1], &p[2], &p[3], &p[4], &p[5]];
            // The coupling overwrites its whole output.
            AffineCoupling::<f64>::new(k % 2, inverse)
                .with_log_scale_bound(self.log_scale_bound)
                .forward(&inputs, &mut y);
            std::mem::swap(&mut x, &mut y);
        }
        pts.as_flattened_mut().copy_from_slice(x.data());
        self.give(x.into_vec());
        self.give(y.into_vec());
    }
}

impl PlainFlow for FusedFlow {
    fn forward(&self, pts: &mut [[f64; 2]]) {
        self.map(pts, false)
    }
    fn inverse(&self, pts: &mut [[f64; 2]]) {
        self.map(pts, true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::CortexRng;
    use autodiff::nn::realnvp::RealNvpConfig;

    /// A flow away from the identity: hidden layers as initialised, the zero-initialised last
    /// layers random (small, so that eight couplings stay well conditioned).
    fn random_flow(seed: u64) -> (RealNvp, ParamStore<f32>) {
        let mut params = ParamStore::<f32>::new();
        let mut rng = CortexRng::seed_from(seed);
        let flow = RealNvp::new(&mut params, "p", RealNvpConfig::default(), &mut rng);
        for ids in flow.param_ids().chunks_exact(PER_BLOCK) {
            for &id in &ids[4..] {
                for v in params.get_mut(id).data_mut() {
                    *v = 0.1 * rng.normal() as f32;
                }
            }
        }
        (flow, params)
    }

    fn points(n: usize, rng: &mut CortexRng) -> Vec<[f64; 2]> {
        (0..n)
            .map(|_| [2.4 * rng.uniform() - 1.2, 2.4 * rng.uniform() - 1.2])
            .collect()
    }

    /// The batched kernel path equals the per-point f64 path of `RealNvp` to rounding, both
    /// ways, on sizes that cover partial chunks and several parallel blocks.
    #[test]
    fn fused_matches_per_point_path() {
        let (flow, params) = random_flow(7);
        let fused = FusedFlow::new(&flow, &params);
        let mut rng = CortexRng::seed_from(8);
        for n in [1, 7, 63, 64, 65, 1000, 2500] {
            let pts = points(n, &mut rng);
            let t = Tensor::from_vec([n, 2], pts.iter().flatten().copied().collect());
            for inverse in [false, true] {
                let want = if inverse {
                    flow.inverse_points(&params, &t)
                } else {
                    flow.forward_points(&params, &t)
                };
                let mut got = pts.clone();
                fused.map(&mut got, inverse);
                let moved = got
                    .iter()
                    .zip(&pts)
                    .map(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs())
                    .fold(0.0, f64::max);
                assert!(moved > 0.1, "the test flow must move points (n {n})");
                for (g, w) in got.iter().flatten().zip(want.data()) {
                    assert!(
                        (g - w).abs() <= 1e-12 * (1.0 + w.abs()),
                        "n {n}, inverse {inverse}: fused {g} vs per-point {w}"
                    );
                }
            }
        }
    }

    #[test]
    fn inverse_after_forward_is_identity_and_empty_is_fine() {
        let (flow, params) = random_flow(9);
        let fused = FusedFlow::new(&flow, &params);
        let mut rng = CortexRng::seed_from(10);
        let pts = points(3000, &mut rng);
        let mut q = pts.clone();
        fused.forward(&mut q);
        fused.inverse(&mut q);
        for (a, b) in q.iter().flatten().zip(pts.iter().flatten()) {
            assert!((a - b).abs() < 1e-10, "{a} vs {b}");
        }
        fused.forward(&mut []);
    }
}
