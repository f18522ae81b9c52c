//! The cortex: buckets W, C, D, P and M wired into decode, translate and re-encode (authors'
//! code, docs/references.md#cortex-pipeline; paper §4, S-03).
//!
//! One prediction, for ONS `O_t`, `O_{t+1}` of shape `(B, 1, n, n)`:
//! 1. decode Φ: `pa = Φ_W(O_t)` (guarded inverse filter) → `X = pa·C` → `V_t = D(X)`
//!    `(B, N, n, n)`. The percept stays in ONS coordinates (authors' code, docs/references.md#cortex-pipeline).
//! 2. motion d̂ from M (oracle, block matching, or learned), no gradient.
//! 3. translate Ω through P: `V̂_{t+1}, mask = warp(V_t, d̂)` (authors' code, docs/references.md#warp).
//! 4. re-encode Ψ: `Ô_{t+1} = Ψ_W(⟨V̂_{t+1}, C⟩)`.
//! 5. loss = masked squared error with a `border_px` border, the authors' normalisation
//!    (docs/references.md#loss);
//!    plus, for the learned M, `blur_loss_weight ×` the same error between the warped blurred
//!    `B(O_t)` and `B(O_{t+1})`; and for any estimated M, `gauge_weight ×` the distance of P's
//!    affine fit from the identity (it leaves P's affine part free: [`crate::buckets::m::gauge`]).
//!
//! Baselines (paper S-05): `identity_percept` skips W, C and D (the percept is the ONS);
//! `no_demosaicker` uses D = identity; `cone_activations_as_ons` changes only the data.
//!
//! Every stretch of the tape is a scope named after its [`Bucket`] (`BUCKET_NAMES`); the
//! U-Net records each of its blocks in a sub-scope `D.inc`, `D.down1`, …, `D.up2`
//! ([`bucket_of_scope`] maps a scope to its bucket). So the trainer times forward and
//! backward per bucket under any learning rule, a rule can be told which buckets to act in,
//! and a layer-local rule knows which block recorded each node. Every hidden layer of decode
//! Φ is tagged for rules that act on layers: `pa` (W, [`TAGS`]), `X` (C), and each layer of
//! the U-Net by its parameter name (`d.inc.conv0`, …, `d.up1.up`, …, `d.outc`, the percept).
//! The prediction `Ô_{t+1}` is the output whose error such rules use; translate and re-encode
//! Ψ∘Ω (P's warp, C's sampling, W's forward filter) form the output mapping and are not
//! tagged: under direct feedback alignment they take the true error, as the output layer
//! does in Nøkland (2016).

use crate::buckets::m::block_matching::{BlockMatcher, DewarpGrid};
use crate::buckets::m::gauge::record_gauge_term;
use crate::buckets::m::learned::SubpixelRefiner;
use crate::buckets::m::sampling::unit_grid;
use crate::buckets::p::{outside_field_guard, Sampling};
use crate::buckets::{c::CBucket, d::DBucket, p::PBucket, w::WBucket};
use crate::config::{Baseline, CortexConfig, MMode};
use crate::CortexError;
use autodiff::{ParamStore, Tape, Tensor, Var};

mod bucket;
pub(crate) use bucket::enter;
pub use bucket::{
    bucket_of_param, bucket_of_scope, Bucket, BUCKETS, BUCKETS_IN_ORDER, BUCKET_NAMES,
    LEARNED_BUCKETS, TAGS,
};

/// What decode Φ leaves on the tape.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// The cone activations `pa = Φ_W(O)`, `(B, 1, n, n)`.
    pub activations: Var,
    /// `X = pa·C`, `(B, N, n, n)` (the activations again in the identity-percept baseline).
    pub injected: Var,
    /// The percept `V = D(X)`, `(B, N, n, n)`.
    pub percept: Var,
    /// The output of each of D's blocks, in forward order (empty when D is the identity);
    /// the last is the percept.
    pub blocks: Vec<Var>,
    /// W's response, when learned.
    pub w: Option<Var>,
    /// The effective C, when present.
    pub c: Option<Var>,
}

/// What one recorded prediction leaves on the tape.
#[derive(Clone, Debug)]
pub struct Prediction {
    /// The training loss (main + blurred objective when M is learned).
    pub loss: Var,
    /// The main loss alone.
    pub main_loss: Var,
    /// The percept `V_t`, `(B, N, n, n)`.
    pub percept: Var,
    /// The predicted `Ô_{t+1}`, `(B, 1, n, n)`.
    pub predicted: Var,
    /// The warp's validity mask, `(B, 1, n, n)`.
    pub mask: Var,
    /// The translated percept `V̂_{t+1}`, `(B, N, n, n)`, what re-encode Ψ reads.
    pub warped: Var,
    /// Decode Φ of `O_t`.
    pub decoded: Decoded,
}

/// The cortex model: its config, parameters and buckets.
pub struct Cortex {
    /// The configuration it was built from.
    pub config: CortexConfig,
    /// Every learnable parameter (`w.*`, `c.*`, `d.*`, `p.*`).
    pub params: ParamStore<f32>,
    pub w: WBucket,
    /// `None` in the identity-percept baseline.
    pub c: Option<CBucket>,
    pub d: DBucket,
    pub p: PBucket,
    matcher: BlockMatcher,
    refiner: SubpixelRefiner,
    /// The ONS grid, where the learned M's gauge term fits P (`motion::gauge`).
    gauge_uv: Vec<[f64; 2]>,
}

/// The motion of one batch.
#[derive(Clone, Debug)]
pub struct MotionOut {
    /// Per sample `[dx, dy]` used for the warp, field units.
    pub motion: Vec<[f64; 2]>,
    /// The blurred frames `(B, n, n)` each, when M computed them.
    pub blurred: Option<(Vec<f32>, Vec<f32>)>,
}

impl Cortex {
    /// Builds the buckets from `config` (validated first), initialised as official: W and P
    /// identity, C = e₁ everywhere, the U-Net with PyTorch's default init seeded by `train.seed`.
    pub fn new(config: CortexConfig) -> Result<Self, CortexError> {
        config.validate()?;
        let mut params = ParamStore::new();
        let identity = config.baseline == Baseline::IdentityPercept;
        let mut wcfg = config.clone();
        if identity {
            wcfg.w.mode = crate::config::WMode::Identity;
            wcfg.d.mode = crate::config::DMode::Identity;
        }
        if config.baseline == Baseline::NoDemosaicker {
            wcfg.d.mode = crate::config::DMode::Identity;
        }
        let w = WBucket::new(&mut params, &wcfg);
        let c = (!identity).then(|| CBucket::new(&mut params, &wcfg));
        let d = DBucket::new(&mut params, &wcfg);
        let p = PBucket::new(&mut params, &wcfg)?;
        let matcher = BlockMatcher::from_config(&config.m);
        let refiner = SubpixelRefiner::from_config(&config);
        let config_n = config.ons_size_px;
        Ok(Cortex {
            config,
            params,
            w,
            c,
            d,
            p,
            matcher,
            refiner,
            gauge_uv: unit_grid(config_n),
        })
    }

    /// ONS side n.
    pub fn n(&self) -> usize {
        self.config.ons_size_px
    }

    /// Channels of the percept (N, or 1 for the identity-percept baseline).
    pub fn percept_dim(&self) -> usize {
        self.config.percept_dim()
    }

    /// Records decode Φ of `ons (B, 1, n, n)` in the W, C and D scopes.
    pub fn record_decode(&self, tape: &mut Tape<f32>, ons: Var) -> Decoded {
        let (pa, x, r, c) = self.record_w_c(tape, ons);
        let Some(c) = c else {
            return Decoded {
                activations: pa,
                injected: pa,
                percept: pa,
                blocks: Vec::new(),
                w: r,
                c: None,
            };
        };
        enter(tape, Bucket::D);
        let (v, blocks) = self.d.forward_blocks(tape, &self.params, x);
        Decoded {
            activations: pa,
            injected: x,
            percept: v,
            blocks,
            w: r,
            c: Some(c),
        }
    }

    /// Records decode Φ's W and C on `ons`: `(pa, X, W's response, C)`; without C (the
    /// identity-percept baseline) `X = pa` and D is not applied after it.
    fn record_w_c(&self, tape: &mut Tape<f32>, ons: Var) -> (Var, Var, Option<Var>, Option<Var>) {
        enter(tape, Bucket::W);
        let r = self.w.record(tape, &self.params);
        let pa = self.w.decode(tape, r, ons);
        tape.tag(pa, TAGS[0]);
        let Some(cb) = &self.c else {
            return (pa, pa, r, None);
        };
        enter(tape, Bucket::C);
        let c = cb.record(tape, &self.params);
        let x = cb.inject(tape, c, pa);
        tape.tag(x, TAGS[1]);
        (pa, x, r, Some(c))
    }

    /// Estimates the motion of frames `(B, n, n)` each (no gradient). `oracle` is required in
    /// oracle mode.
    pub fn estimate_motion(
        &self,
        frame_t: &[f32],
        frame_t1: &[f32],
        oracle: Option<&[[f32; 2]]>,
    ) -> Result<MotionOut, CortexError> {
        let n = self.n();
        match self.config.m.mode {
            MMode::Oracle => {
                let o = oracle.ok_or_else(|| CortexError::InvalidBatch {
                    field: "oracle_motion",
                    reason: "this run uses oracle motion (m.mode = \"oracle\") but the batch carries none".into(),
                })?;
                Ok(MotionOut {
                    motion: o.iter().map(|d| [d[0] as f64, d[1] as f64]).collect(),
                    blurred: None,
                })
            }
            MMode::BlockMatching | MMode::Learned => {
                let flow = self.p.plain(&self.params);
                let b1 = self.matcher.blur(frame_t, n);
                let b2 = self.matcher.blur(frame_t1, n);
                let grid = DewarpGrid::new(flow.as_ref(), n, 2 * n.next_power_of_two());
                let est = self.matcher.estimate_blurred(&b1, &b2, n, &grid);
                if self.config.m.mode == MMode::BlockMatching {
                    return Ok(MotionOut {
                        motion: est.motion,
                        blurred: None,
                    });
                }
                let motion = self
                    .refiner
                    .refine(&b1, &b2, n, flow.as_ref(), &grid, &est.motion);
                Ok(MotionOut {
                    motion,
                    blurred: Some((b1, b2)),
                })
            }
        }
    }

    /// Records one whole prediction and its loss. `o1`, `o2` are `(B, 1, n, n)` constants.
    pub fn record_prediction(
        &self,
        tape: &mut Tape<f32>,
        o1: Var,
        o2: Var,
        motion: &MotionOut,
    ) -> Prediction {
        let (b, _, n, _) = tape.shape(o1).bchw("Cortex::record_prediction");
        let decoded = self.record_decode(tape, o1);
        let (v1, r, c) = (decoded.percept, decoded.w, decoded.c);
        enter(tape, Bucket::P);
        let extra: Vec<Var> = match &motion.blurred {
            Some((b1, _)) => vec![tape.constant_from([b, 1, n, n], b1)],
            None => Vec::new(),
        };
        let sampling = self.p.sampling(tape, &self.params, &motion.motion);
        let (v2, mask, extra_w) = PBucket::resample_with(tape, &sampling, v1, &extra);
        let pa2 = match (&self.c, c) {
            (Some(cb), Some(c)) => {
                enter(tape, Bucket::C);
                cb.sample(tape, c, v2)
            }
            _ => v2,
        };
        enter(tape, Bucket::W);
        let pred = self.w.encode(tape, r, pa2);
        enter(tape, Bucket::Loss);
        let border = self.config.loss.border_px;
        let main = tape.masked_sq_error(pred, o2, mask, border);
        let mut loss = match (&motion.blurred, extra_w.first()) {
            (Some((_, b2)), Some(&bw)) if self.config.m.blur_loss_weight > 0.0 => {
                let b2v = tape.constant_from([b, 1, n, n], b2);
                let e = tape.masked_sq_error(bw, b2v, mask, border);
                let e = tape.scale(e, self.config.m.blur_loss_weight);
                tape.add(main, e)
            }
            _ => main,
        };
        let guard_weight = self.config.loss.outside_field_weight;
        if let (true, Sampling::Grid(grid)) = (guard_weight > 0.0, &sampling) {
            let g = outside_field_guard(tape, *grid);
            let g = tape.scale(g, guard_weight);
            loss = tape.add(loss, g);
        }
        // An estimated M (block matching or learned) measures d̂ through P, which leaves P's
        // affine part free (see `motion::gauge`): pin it to the identity.
        if let (true, PBucket::Flow { flow, uv, .. }) =
            (self.config.m.mode != MMode::Oracle, &self.p)
        {
            // in the main loss's normalisation: a sum over the loss sites
            let sites = (n - 2 * border).pow(2) as f64;
            let wgt = self.config.m.gauge_weight * sites;
            if wgt > 0.0 {
                enter(tape, Bucket::P);
                let vars = flow.record(tape, &self.params);
                let pts = tape.constant_from([uv.len() / 2, 2], uv);
                let xy = flow.forward_with(tape, &vars, pts);
                let g = record_gauge_term(tape, xy, &self.gauge_uv);
                let g = tape.scale(g, wgt);
                loss = tape.add(loss, g);
            }
        }
        tape.close_scope();
        Prediction {
            loss,
            main_loss: main,
            percept: v1,
            predicted: pred,
            mask,
            warped: v2,
            decoded,
        }
    }

    /// Decodes ONS frames `(B, n, n)` to percepts `(B, N, n, n)` (evaluation; no learning).
    pub fn decode_frames(&self, ons: &[f32], batch: usize) -> Vec<f32> {
        let mut tape = Tape::<f32>::new();
        let o = self.constant_frames(&mut tape, ons, batch, "Cortex::decode_frames");
        let v = self.record_decode(&mut tape, o).percept;
        tape.value(v).data().to_vec()
    }

    /// ONS frames `(B × n × n)` as a constant `(B, 1, n, n)` on `tape`, their length checked.
    #[track_caller]
    pub(crate) fn constant_frames(
        &self,
        tape: &mut Tape<f32>,
        ons: &[f32],
        batch: usize,
        caller: &str,
    ) -> Var {
        let n = self.n();
        assert_eq!(
            ons.len(),
            batch * n * n,
            "{caller}: {} values for (B={batch}, {n}, {n})",
            ons.len()
        );
        tape.constant_from([batch, 1, n, n], ons)
    }

    /// The learned cone types, `(n, n, N)` unit vectors (`None` in the identity baseline).
    pub fn learned_c(&self) -> Option<Tensor<f64>> {
        self.c.as_ref().map(|c| c.effective(&self.params))
    }

    /// The learned cell positions `xy = P(uv)` of every ONS cell, `(n, n, 2)` (x, y).
    pub fn learned_positions(&self) -> Tensor<f64> {
        let n = self.n();
        let mut pts = crate::buckets::m::sampling::unit_grid(n);
        self.p.plain(&self.params).forward(&mut pts);
        Tensor::from_vec([n, n, 2], pts.into_iter().flatten().collect())
    }

    /// The learned lateral-inhibition kernel, `k×k` around its origin (official logging: 7).
    pub fn learned_w_kernel(&self, k: usize) -> Option<Tensor<f64>> {
        self.w.kernel(&self.params, k)
    }

    /// Sets W to the filter of a `k×k` kernel (diagnostics only: see
    /// [`crate::buckets::w::WBucket::set_kernel`]); `false` when W is not learned.
    pub fn set_w_kernel(&mut self, kernel: &Tensor<f64>) -> bool {
        self.w.set_kernel(&mut self.params, kernel)
    }

    /// The learned lateral-inhibition filter's gain at zero frequency (the sum of its kernel).
    pub fn learned_w_dc_gain(&self) -> Option<f64> {
        self.w.dc_gain(&self.params)
    }

    /// Sets W's gain at zero frequency, keeping every other frequency (diagnostics only: see
    /// [`crate::buckets::w::WBucket::set_dc_gain`]); `false` when W is not learned.
    pub fn set_w_dc_gain(&mut self, gain: f64) -> bool {
        self.w.set_dc_gain(&mut self.params, gain)
    }
}
