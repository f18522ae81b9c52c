//! P, the cell positions (authors' code, docs/references.md#p-bucket and #warp; paper S-03 "Learning Cell Positions"), and the
//! efficient warp that predicts the next percept.
//!
//! - [`PMode::Flow`]: the RealNVP of `autodiff::nn::realnvp` (official: 8 couplings, MLP
//!   1→16→16→2, last layer zero, so the identity at start; 2 704 parameters under `p.`).
//!   `xy = P(uv)` is a cell's believed position in the visual field; `uv ∈ [−1, 1]²` is the ONS
//!   grid (align-corners). The efficient warp (authors' code, docs/references.md#warp), for every ONS pixel uv:
//!   `xy = P(uv)`, `xy' = xy + d̂_b`, `uv' = P⁻¹(xy')`, `V̂(uv) = bilinear(V, uv')` (zeros
//!   outside), `mask(uv)` = nearest sample of ones at uv'. Gradients reach P only through the
//!   sampling coordinates uv'.
//! - [`PMode::IdentityIntegerShift`] (sandbox): positions are the ONS grid; the motion is
//!   rounded to whole pixels (`round(d · motion_ons_px_per_unit)`) and applied by
//!   [`super::shift::integer_shift_warp`].
//!
//! Every warp returns `(warped (B, C, n, n), mask (B, 1, n, n))`; `extra` images (the blurred
//! ONS of the learned motion estimator) are warped through the same sampling grid.

use super::p_plain::FusedFlow;
use super::shift::integer_shift_warp;
use crate::buckets::m::sampling::unit_grid;
use crate::buckets::m::{IdentityFlow, PlainFlow};
use crate::config::{CortexConfig, PMode};
use crate::rng::CortexRng;
use crate::CortexError;
use autodiff::nn::realnvp::{RealNvp, RealNvpConfig};
use autodiff::{ParamStore, Tape, Var};

/// The P bucket.
pub enum PBucket {
    /// The learned flow, with the ONS grid `(n², 2)` as f32 `(u_x, u_y)` pairs.
    Flow {
        flow: RealNvp,
        uv: Vec<f32>,
        n: usize,
    },
    /// Identity positions, integer shifts.
    IdentityIntegerShift {
        /// ONS pixels per unit of motion.
        px_per_unit: f64,
    },
}

impl PBucket {
    /// Builds P (adding the flow's parameters when P is learned).
    pub fn new(params: &mut ParamStore<f32>, cfg: &CortexConfig) -> Result<Self, CortexError> {
        match cfg.p.mode {
            PMode::IdentityIntegerShift => Ok(PBucket::IdentityIntegerShift {
                px_per_unit: cfg.p.motion_ons_px_per_unit,
            }),
            PMode::Flow => {
                let mut rng = CortexRng::seed_from(cfg.train.seed ^ 0x5043_454c_4c53); // "PCELLS"
                let flow = RealNvp::new(
                    params,
                    "p",
                    RealNvpConfig {
                        blocks: cfg.p.couplings,
                        hidden: cfg.p.hidden,
                        log_scale_bound: cfg.p.log_scale_bound,
                    },
                    &mut rng,
                );
                let n = cfg.ons_size_px;
                let uv = unit_grid(n)
                    .into_iter()
                    .flatten()
                    .map(|v| v as f32)
                    .collect();
                Ok(PBucket::Flow { flow, uv, n })
            }
        }
    }

    /// P as a plain f64 map at the current parameters (for M's de-warping and for evaluation),
    /// batched through the fused coupling kernel ([`super::p_plain`]).
    pub fn plain<'a>(&'a self, params: &'a ParamStore<f32>) -> Box<dyn PlainFlow + 'a> {
        match self {
            PBucket::Flow { flow, .. } => Box::new(FusedFlow::new(flow, params)),
            PBucket::IdentityIntegerShift { .. } => Box::new(IdentityFlow),
        }
    }

    /// The sampling of a warp by `motion` (field units, per sample): P's grid on the tape, or
    /// integer shifts. Recording it once lets several images share it ([`PBucket::resample`]).
    pub fn sampling(
        &self,
        tape: &mut Tape<f32>,
        params: &ParamStore<f32>,
        motion: &[[f64; 2]],
    ) -> Sampling {
        match self {
            PBucket::Flow { flow, uv, n } => {
                let (b, nn) = (motion.len(), n * n);
                let vars = flow.record(tape, params);
                let uv = tape.constant_from([nn, 2], uv);
                let xy = flow.forward_with(tape, &vars, uv);
                let mut d = tape.alloc([b, nn, 2]);
                for (chunk, m) in d.data_mut().chunks_mut(2 * nn).zip(motion) {
                    for p in chunk.chunks_mut(2) {
                        p[0] = m[0] as f32;
                        p[1] = m[1] as f32;
                    }
                }
                let d = tape.constant(d);
                let xy_moved = tape.add_broadcast(d, xy);
                let xy_moved = tape.reshape(xy_moved, [b * nn, 2]);
                let uv_moved = flow.inverse_with(tape, &vars, xy_moved);
                Sampling::Grid(tape.reshape(uv_moved, [b, *n, *n, 2]))
            }
            PBucket::IdentityIntegerShift { px_per_unit } => Sampling::Shift(
                motion
                    .iter()
                    .map(|d| {
                        [
                            (d[0] * px_per_unit).round() as i64,
                            (d[1] * px_per_unit).round() as i64,
                        ]
                    })
                    .collect(),
            ),
        }
    }

    /// Warps `v (B, C, n, n)` through `sampling`; returns `(warped, mask (B, 1, n, n))`.
    pub fn resample(tape: &mut Tape<f32>, sampling: &Sampling, v: Var) -> (Var, Var) {
        match sampling {
            Sampling::Grid(grid) => {
                let (_, _, h, w) = tape.shape(v).bchw("PBucket::resample");
                let warped = tape.grid_sample(v, *grid);
                (warped, tape.grid_sample_mask(*grid, h, w))
            }
            Sampling::Shift(shifts) => integer_shift_warp(tape, v, shifts),
        }
    }

    /// Warps `v` (and each of `extra`) by `motion` (field units, per sample).
    pub fn warp(
        &self,
        tape: &mut Tape<f32>,
        params: &ParamStore<f32>,
        v: Var,
        extra: &[Var],
        motion: &[[f64; 2]],
    ) -> (Var, Var, Vec<Var>) {
        let sampling = self.sampling(tape, params, motion);
        Self::resample_with(tape, &sampling, v, extra)
    }

    /// Warps `v` through `sampling` as [`PBucket::resample`], and each of `extra` through the
    /// same sampling: `(warped, mask, extra warped)`.
    pub fn resample_with(
        tape: &mut Tape<f32>,
        sampling: &Sampling,
        v: Var,
        extra: &[Var],
    ) -> (Var, Var, Vec<Var>) {
        let (warped, mask) = Self::resample(tape, sampling, v);
        let ex = extra
            .iter()
            .map(|&e| Self::resample(tape, sampling, e).0)
            .collect();
        (warped, mask, ex)
    }
}

/// The outside-field guard of a sampling grid `(B, n, n, 2)` (align-corners coordinates, the
/// field is [−1, 1]²): `Σ_pixels mean_batch Σ_axes relu(|u′| − 1)²`, a scalar. It is 0 while
/// every point is inside and grows with the square of how far points lie outside, so it has a
/// gradient where the warp's mask is empty ([`crate::config::LossConfig::outside_field_weight`]).
pub fn outside_field_guard(tape: &mut Tape<f32>, grid: Var) -> Var {
    let batch = tape.shape(grid).dims()[0];
    let a = tape.abs(grid);
    let a = tape.add_scalar(a, -1.0);
    let outside = tape.relu(a);
    let sq = tape.square(outside);
    let total = tape.sum(sq);
    tape.scale(total, 1.0 / batch as f64)
}

/// How a warp samples: P's grid `(B, n, n, 2)` on the tape, or whole-pixel shifts per sample.
#[derive(Clone, Debug)]
pub enum Sampling {
    /// The flow's sampling grid (align-corners coordinates).
    Grid(Var),
    /// `[dx, dy]` ONS pixels per sample.
    Shift(Vec<[i64; 2]>),
}
