//! Every number of the cortex as a config value, and the five presets.
//!
//! A [`CortexConfig`] is plain data (serde, TOML-friendly: tables per bucket). Physical or
//! pixel-valued numbers carry their unit in the name (`ons_size_px`, `blur_sigma_px`); each
//! default cites its source: the authors' code by an entry of `docs/references.md`, "paper
//! S-03" the paper's supplement.
//!
//! Presets (named sets of values, [`CortexConfig::preset`]):
//! - `tiny`: tests in seconds. 32×32 ONS, U-Net 8/16, N = 8, batch 4, oracle motion (block
//!   matching, when switched on, starts at 8×8: a 4×4 level of a 32² ONS carries no signal).
//! - `quick`: the default CPU run. 64×64 ONS, U-Net 16/32/64, learned W and P, block matching.
//! - `large`: the quick cortex on a 128×128 ONS (the `large` eye's 128² cones): U-Net 16/32/64,
//!   so its receptive fields span the same number of cone spacings as `quick`'s.
//! - `sandbox`: the official sandbox (authors' code, docs/references.md#sandbox): 64×64, W identity, P identity with
//!   integer shifts, oracle motion, U-Net 16/32/64.
//! - `paper`: official everything (authors' code, docs/references.md#cortex-pipeline): 256×256, U-Net 16/32/64/128, block matching.

mod per_bucket;
mod presets;
mod train;
mod validate;

pub use per_bucket::{BucketTrain, PerBucketTrain};
pub use train::{LrSchedule, TrainConfig};

pub use crate::optimizer::OptimizerName;
use serde::{Deserialize, Serialize};

/// How the W bucket (lateral-inhibition weights) acts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WMode {
    /// Free complex frequency response on the (2n−1)² grid (authors' code, docs/references.md#w-bucket).
    Learned,
    /// No-op, as in the official sandbox (authors' code `Identity`, docs/references.md#w-bucket).
    Identity,
}

/// How the D bucket (demosaicker) acts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DMode {
    /// The U-Net (authors' code, docs/references.md#d-bucket).
    UNet,
    /// D = identity: the "no demosaicker" baseline of paper S-05.
    Identity,
}

/// How the P bucket (cell positions) acts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PMode {
    /// RealNVP flow, identity at start, efficient warp (authors' code, docs/references.md#p-bucket and #warp).
    Flow,
    /// Identity positions; the motion is rounded to whole ONS pixels and applied as a zero-padded
    /// gather (authors' code, docs/references.md#p-bucket, sandbox variant). Nothing to learn.
    IdentityIntegerShift,
}

/// Where the eye motion d̂ comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MMode {
    /// The true motion supplied with the batch (authors' code `GroundTruth`, docs/references.md#motion-estimation).
    Oracle,
    /// Coarse-to-fine pyramid block matching on blurred, P-de-warped ONS (authors' code, docs/references.md#motion-estimation).
    BlockMatching,
    /// Block matching refined to sub-pixel precision by Gauss–Newton on the blurred warp error,
    /// with P also trained on that blurred objective (paper S-03, "Learning Eye Motion
    /// Estimation"). See [`crate::buckets::m::learned`].
    Learned,
}

/// The paper's S-05 baselines. `None` is the full model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Baseline {
    /// The full cortex.
    None,
    /// Φ = identity: the percept is the ONS itself (one channel), Ψ = identity; only the warp
    /// (P, M) remains.
    IdentityPercept,
    /// Cone activations as the ONS. The cortex is unchanged; the **data source** must deliver
    /// cone activations instead of laterally inhibited signals (the root package honours this).
    ConeActivationsAsOns,
    /// No demosaicker: D = identity.
    NoDemosaicker,
}

/// W bucket settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WConfig {
    /// Learned or identity.
    pub mode: WMode,
    /// ε of the guarded inverse X·conj(W)/(|W|² + ε) (the authors' code has none; docs/references.md#guarded-w-inverse).
    pub inverse_guard: f64,
}

/// C bucket settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CConfig {
    /// ε of the per-cell normalisation C = raw/(‖raw‖ + ε) (authors' code, docs/references.md#c-bucket: 1e-5).
    pub norm_eps: f64,
}

/// D bucket settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DConfig {
    /// U-Net or identity.
    pub mode: DMode,
    /// Encoder widths, one per level (authors' code, docs/references.md#d-bucket: 16/32/64/128; sandbox 16/32/64).
    pub widths: Vec<usize>,
}

/// P bucket settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PConfig {
    /// Flow or identity with integer shifts.
    pub mode: PMode,
    /// Affine coupling blocks of the RealNVP (authors' code, docs/references.md#p-bucket: 8).
    pub couplings: usize,
    /// Hidden width of each coupling MLP 1→h→h→2 (authors' code, docs/references.md#p-bucket: 16).
    pub hidden: usize,
    /// Bound `a` on each coupling's log-scale, `s = a·tanh(ŝ/a)`, so that P and P⁻¹ scale a
    /// coordinate by at most `e^a` per coupling and can never overflow
    /// (`autodiff::nn::coupling`). Absent: unbounded, the authors' code, whose `exp(−s)` can
    /// overflow in P⁻¹(P(uv) + d̂) and end training with a non-finite gradient; a config
    /// written before the bound existed reads back as unbounded. Default 2 (a factor of
    /// e² ≈ 7.4 per coupling, far beyond the foveated lattice's 1.9 centre-to-edge spacing
    /// ratio, docs/references.md#foveation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub log_scale_bound: Option<f64>,
    /// ONS pixels per unit of motion, used only by `identity_integer_shift` to turn d into whole
    /// pixels. The oracle is shift/(R/2) with R the field in px (authors' code, docs/references.md#retina-data-flow); in the sandbox
    /// the field is the ONS, so this is n/2.
    pub motion_ons_px_per_unit: f64,
}

/// M (eye-motion) settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MConfig {
    /// Oracle, block matching, or learned.
    pub mode: MMode,
    /// Side of the Gaussian blur kernel B (authors' code, docs/references.md#motion-estimation: 9).
    pub blur_kernel_px: usize,
    /// σ of B (authors' code, docs/references.md#motion-estimation: 2 px).
    pub blur_sigma_px: f64,
    /// Integer search radius per pyramid level (authors' code, docs/references.md#motion-estimation: 2, i.e. 25 candidates).
    pub search_radius_px: i32,
    /// Side of the coarsest pyramid level (authors' code, docs/references.md#motion-estimation: 4).
    pub coarsest_level_px: usize,
    /// Block-matching candidates overlapping less than this fraction of the valid pixels are
    /// skipped (our addition; 0 = official behaviour, see [`crate::buckets::m::block_matching`]).
    pub min_overlap_fraction: f64,
    /// Gauss–Newton iterations of the learned estimator's sub-pixel refinement.
    pub refine_iterations: usize,
    /// Central-difference step of the refinement's Jacobian, in de-warped pixels.
    pub refine_fd_step_px: f64,
    /// Pixel stride of the refinement's samples (cost control at large n).
    pub refine_stride_px: usize,
    /// Largest refinement per iteration, in de-warped pixels (a trust region).
    pub refine_max_step_px: f64,
    /// Weight of the blurred warp objective added to the loss for P (learned mode only).
    pub blur_loss_weight: f64,
    /// Weight of the gauge term for an estimated M (block matching and learned modes; see
    /// [`crate::buckets::m::gauge`]): the squared distance of P's least-squares affine fit over the
    /// ONS grid from the identity. When the motion is estimated through P, any affine change
    /// of the visual-field coordinates (P → A·P + c, d → A·d) predicts exactly the same
    /// frames, so the prediction loss does not fix P's affine part and Adam lets it drift
    /// without bound; this term pins it. Per loss site: the term is multiplied by the number
    /// of sites the main loss sums over (`(n − 2·border)²`), so its pull against the loss's
    /// gradients does not depend on n.
    #[serde(default = "default_gauge_weight")]
    pub gauge_weight: f64,
}

/// [`MConfig::gauge_weight`] when a config file (or a checkpoint written before the field
/// existed) leaves it out.
fn default_gauge_weight() -> f64 {
    1.0
}

/// Loss settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LossConfig {
    /// Border dropped on each side (authors' code, docs/references.md#loss: ⌊7/2⌋ = 3 px).
    pub border_px: usize,
    /// Weight of the outside-field guard (0, the default and the authors' loss: none). The
    /// prediction loss is 0 with no gradient when P moves every sampling point out of the field
    /// (the empty warp); the guard adds `weight · Σ_pixels mean_batch Σ_axes relu(|u′| − 1)²`
    /// over the warp's sampling coordinates `u′` (align-corners, the field is [−1, 1]²) at
    /// every ONS pixel, border included: a sum over pixels, as the main loss is a sum over its
    /// sites (which divides by the batch's mask count plus one instead). It is 0 wherever
    /// every point is inside.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub outside_field_weight: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The whole cortex configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CortexConfig {
    /// Side n of the square ONS (authors' code, docs/references.md#retina-data-flow: 256).
    pub ons_size_px: usize,
    /// Percept dimension N (authors' code, docs/references.md#cortex-pipeline: 8).
    pub percept_channels: usize,
    /// Baseline of paper S-05, or `none`.
    pub baseline: Baseline,
    pub w: WConfig,
    pub c: CConfig,
    pub d: DConfig,
    pub p: PConfig,
    pub m: MConfig,
    pub loss: LossConfig,
    pub train: TrainConfig,
}

/// Largest ONS side accepted (the paper uses 256).
pub const MAX_ONS_SIZE_PX: usize = 2048;

/// Largest U-Net width, percept dimension, coupling count or hidden width accepted.
pub const MAX_WIDTH: usize = 4096;

/// Largest `batch_size · ons_size_px²` accepted: 2²⁶ values (256 MiB per f32 frame batch; the
/// paper's batch is 2¹⁹).
pub const MAX_BATCH_ONS_VALUES: usize = 1 << 26;

/// Names accepted by [`CortexConfig::preset`].
pub const PRESETS: &[&str] = &["tiny", "quick", "large", "sandbox", "paper"];

impl CortexConfig {
    /// Channels of the percept: N, or 1 for the Φ = identity baseline.
    pub fn percept_dim(&self) -> usize {
        if self.baseline == Baseline::IdentityPercept {
            1
        } else {
            self.percept_channels
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate_and_round_trip_through_toml() {
        for name in PRESETS {
            let c = CortexConfig::preset(name).unwrap();
            c.validate().unwrap();
            let text = toml::to_string(&c).unwrap();
            let back: CortexConfig = toml::from_str(&text).unwrap();
            assert_eq!(back, c, "{name}");
        }
        assert!(CortexConfig::preset("huge").is_err());
    }

    #[test]
    fn presets_follow_the_official_numbers() {
        let p = CortexConfig::paper();
        assert_eq!(
            (p.ons_size_px, p.percept_channels, p.train.batch_size),
            (256, 8, 8)
        );
        assert_eq!(p.train.learning_rate, 1e-3);
        assert_eq!(p.d.widths, vec![16, 32, 64, 128]);
        let s = CortexConfig::sandbox();
        assert_eq!(
            (s.w.mode, s.p.mode, s.m.mode),
            (WMode::Identity, PMode::IdentityIntegerShift, MMode::Oracle)
        );
        assert_eq!(s.d.widths, vec![16, 32, 64]);
        let (q, l) = (CortexConfig::quick(), CortexConfig::large());
        assert_eq!(
            (l.ons_size_px, l.d.widths.clone()),
            (128, q.d.widths.clone())
        );
        assert_eq!(
            l.p.motion_ons_px_per_unit / l.ons_size_px as f64,
            q.p.motion_ons_px_per_unit / q.ons_size_px as f64,
            "one unit of eye motion is the same fraction of the field"
        );
    }

    #[test]
    fn cosine_schedule_runs_from_the_rate_to_its_floor() {
        let mut t = CortexConfig::quick().train;
        t.steps = 1000;
        t.final_lr_fraction = 0.1;
        assert_eq!(t.learning_rate_at(700), t.learning_rate, "constant");
        t.lr_schedule = LrSchedule::Cosine;
        let lr = |s| t.learning_rate_at(s) / t.learning_rate;
        assert_eq!(lr(0), 1.0);
        assert!((lr(500) - 0.55).abs() < 1e-12, "{}", lr(500));
        assert!((lr(1000) - 0.1).abs() < 1e-12 && lr(5000) == lr(1000));
        assert!((1..1000).all(|s| lr(s) < lr(s - 1)), "strictly falling");
        t.final_lr_fraction = 0.0;
        let mut c = CortexConfig::quick();
        c.train = t;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("final_lr_fraction"), "{e}");
    }

    #[test]
    fn typo_in_a_field_is_an_error_naming_it() {
        let mut text = toml::to_string(&CortexConfig::tiny()).unwrap();
        text = text.replace("border_px", "boarder_px");
        let err = toml::from_str::<CortexConfig>(&text)
            .unwrap_err()
            .to_string();
        assert!(err.contains("boarder_px"), "{err}");
    }

    #[test]
    fn validate_rejects_bad_values_by_field() {
        let mut c = CortexConfig::tiny();
        c.ons_size_px = 31;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("d.widths"), "{e}");
        let mut c = CortexConfig::tiny();
        c.m.blur_kernel_px = 8;
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("m.blur_kernel_px"));
    }
}
