//! Every number of the cortex as a config value, and the four presets.
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
//! - `sandbox`: the official sandbox (authors' code, docs/references.md#sandbox): 64×64, W identity, P identity with
//!   integer shifts, oracle motion, U-Net 16/32/64.
//! - `paper`: official everything (authors' code, docs/references.md#cortex-pipeline): 256×256, U-Net 16/32/64/128, block matching.

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
}

/// Optimisation settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    /// Samples per step (authors' code, docs/references.md#training: 8).
    pub batch_size: usize,
    /// Adam learning rate (authors' code, docs/references.md#training: 1e-3).
    pub learning_rate: f64,
    /// Adam β₁ (authors' code, docs/references.md#training: PyTorch default 0.9).
    pub adam_beta1: f64,
    /// Adam β₂ (authors' code, docs/references.md#training: 0.999).
    pub adam_beta2: f64,
    /// Adam ε (authors' code, docs/references.md#training: 1e-8).
    pub adam_eps: f64,
    /// Seed of parameter initialisation (authors' code, docs/references.md#training: 1234).
    pub seed: u64,
    /// Gradient updates of a run (authors' code, docs/references.md#training: 100 000).
    pub steps: u64,
    /// Steps between checkpoints of a run (0: none but the last).
    pub checkpoint_every_steps: u64,
    /// Factor on the learning rate of W's response (1: the authors' single learning rate).
    /// W is identified only weakly by the loss (see `colorvision convergence` and
    /// `colorvision w-dc-gauge`); a larger factor lets Adam move it further per step, 0 holds W
    /// where it starts.
    #[serde(default = "unit_scale")]
    pub w_learning_rate_scale: f64,
    /// How the learning rate changes over the run's `steps` ([`LrSchedule`]; default constant,
    /// as the authors' code).
    #[serde(default)]
    pub lr_schedule: LrSchedule,
    /// Learning rate at the last step as a fraction of `learning_rate` (cosine schedule only).
    #[serde(default = "default_final_lr_fraction")]
    pub final_lr_fraction: f64,
}

fn unit_scale() -> f64 {
    1.0
}

fn default_final_lr_fraction() -> f64 {
    0.01
}

/// The learning rate over training.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LrSchedule {
    /// `learning_rate` at every step (authors' code, docs/references.md#training).
    #[default]
    Constant,
    /// Half a cosine from `learning_rate` at step 0 to `final_lr_fraction · learning_rate` at
    /// step `steps` (Loshchilov & Hutter 2017, SGDR, without restarts); held there after.
    Cosine,
}

impl TrainConfig {
    /// The learning rate of gradient update `step` (0-based) under the schedule.
    pub fn learning_rate_at(&self, step: u64) -> f64 {
        match self.lr_schedule {
            LrSchedule::Constant => self.learning_rate,
            LrSchedule::Cosine => {
                let progress = (step as f64 / self.steps.max(1) as f64).min(1.0);
                let floor = self.final_lr_fraction;
                let factor =
                    floor + (1.0 - floor) * 0.5 * (1.0 + (std::f64::consts::PI * progress).cos());
                self.learning_rate * factor
            }
        }
    }
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
pub const PRESETS: &[&str] = &["tiny", "quick", "sandbox", "paper"];

impl CortexConfig {
    /// The official full model (authors' code, docs/references.md#cortex-pipeline) at `paper` size.
    pub fn paper() -> Self {
        CortexConfig {
            ons_size_px: 256,
            percept_channels: 8,
            baseline: Baseline::None,
            w: WConfig {
                mode: WMode::Learned,
                inverse_guard: 1e-6,
            },
            c: CConfig { norm_eps: 1e-5 },
            d: DConfig {
                mode: DMode::UNet,
                widths: vec![16, 32, 64, 128],
            },
            p: PConfig {
                mode: PMode::Flow,
                couplings: 8,
                hidden: 16,
                motion_ons_px_per_unit: 128.0,
            },
            m: MConfig {
                mode: MMode::BlockMatching,
                blur_kernel_px: 9,
                blur_sigma_px: 2.0,
                search_radius_px: 2,
                coarsest_level_px: 4,
                min_overlap_fraction: 0.5,
                refine_iterations: 2,
                refine_fd_step_px: 0.25,
                refine_stride_px: 4,
                refine_max_step_px: 1.0,
                blur_loss_weight: 1.0,
                gauge_weight: default_gauge_weight(),
            },
            loss: LossConfig { border_px: 3 },
            train: TrainConfig {
                batch_size: 8,
                learning_rate: 1e-3,
                adam_beta1: 0.9,
                adam_beta2: 0.999,
                adam_eps: 1e-8,
                seed: 1234,
                steps: 100_000,
                checkpoint_every_steps: 1000,
                w_learning_rate_scale: 1.0,
                lr_schedule: LrSchedule::Constant,
                final_lr_fraction: default_final_lr_fraction(),
            },
        }
    }

    /// The default CPU run: 64×64, full model with learned W and P, U-Net 16/32/64.
    pub fn quick() -> Self {
        let mut c = Self::paper();
        c.ons_size_px = 64;
        c.d.widths = vec![16, 32, 64];
        c.p.motion_ons_px_per_unit = 32.0;
        c.m.refine_stride_px = 1;
        c.train.steps = 5_000;
        c.train.checkpoint_every_steps = 500;
        c
    }

    /// The official sandbox (authors' code, docs/references.md#sandbox): W identity, P identity with integer shifts,
    /// oracle motion, 2-level U-Net.
    pub fn sandbox() -> Self {
        let mut c = Self::quick();
        c.w.mode = WMode::Identity;
        c.p.mode = PMode::IdentityIntegerShift;
        c.m.mode = MMode::Oracle;
        c
    }

    /// Tests in seconds: 32×32, U-Net 8/16, batch 4, oracle motion.
    pub fn tiny() -> Self {
        let mut c = Self::quick();
        c.ons_size_px = 32;
        c.d.widths = vec![8, 16];
        c.p.motion_ons_px_per_unit = 16.0;
        c.m.mode = MMode::Oracle;
        c.m.coarsest_level_px = 8;
        c.train.batch_size = 4;
        c.train.steps = 300;
        c.train.checkpoint_every_steps = 100;
        c
    }

    /// A preset by name (see [`PRESETS`]).
    pub fn preset(name: &str) -> Result<Self, crate::CortexError> {
        match name {
            "tiny" => Ok(Self::tiny()),
            "quick" => Ok(Self::quick()),
            "sandbox" => Ok(Self::sandbox()),
            "paper" => Ok(Self::paper()),
            other => Err(crate::CortexError::UnknownPreset(other.to_string())),
        }
    }

    /// Checks the values that would otherwise panic deep inside an op.
    pub fn validate(&self) -> Result<(), crate::CortexError> {
        let n = self.ons_size_px;
        if n < 8 {
            return invalid("ons_size_px", format!("{n} is below the minimum of 8"));
        }
        if self.percept_channels == 0 {
            return invalid("percept_channels", "must be at least 1".into());
        }
        self.validate_sizes()?;
        self.validate_unet()?;
        if 2 * self.loss.border_px >= n {
            return invalid(
                "loss.border_px",
                format!("{} leaves no pixels of a {n}² ONS", self.loss.border_px),
            );
        }
        self.validate_motion_blur()?;
        self.validate_optimiser()?;
        self.validate_buckets()?;
        self.validate_training()
    }

    /// Checks the U-Net widths of the D bucket (when D is a U-Net): each level's width in range,
    /// and the ONS side divisible by the downsampling of the deepest level.
    fn validate_unet(&self) -> Result<(), crate::CortexError> {
        if self.d.mode != DMode::UNet {
            return Ok(());
        }
        let n = self.ons_size_px;
        if self.d.widths.is_empty() {
            return invalid("d.widths", "a U-Net needs at least one level".into());
        }
        if let Some(w) = self.d.widths.iter().find(|&&w| w == 0 || w > MAX_WIDTH) {
            return invalid(
                "d.widths",
                format!(
                    "{:?}: each width must be 1..={MAX_WIDTH}, got {w}",
                    self.d.widths
                ),
            );
        }
        let div = 1usize << (self.d.widths.len() - 1);
        if !n.is_multiple_of(div) {
            return invalid(
                "d.widths",
                format!(
                    "{} levels need ons_size_px divisible by {div}, got {n}",
                    self.d.widths.len()
                ),
            );
        }
        Ok(())
    }

    /// Checks the M bucket's blur kernel, gauge weight and pyramid.
    fn validate_motion_blur(&self) -> Result<(), crate::CortexError> {
        let n = self.ons_size_px;
        if self.m.blur_kernel_px.is_multiple_of(2) || self.m.blur_kernel_px / 2 >= n {
            return invalid(
                "m.blur_kernel_px",
                format!(
                    "{} must be odd and smaller than the ONS",
                    self.m.blur_kernel_px
                ),
            );
        }
        if !(self.m.gauge_weight.is_finite() && self.m.gauge_weight >= 0.0) {
            return invalid(
                "m.gauge_weight",
                format!("{} must be finite and ≥ 0", self.m.gauge_weight),
            );
        }
        if self.m.blur_sigma_px.is_nan() || self.m.blur_sigma_px <= 0.0 {
            return invalid(
                "m.blur_sigma_px",
                format!("{} must be positive", self.m.blur_sigma_px),
            );
        }
        if self.m.coarsest_level_px < 2 || !self.m.coarsest_level_px.is_power_of_two() {
            return invalid(
                "m.coarsest_level_px",
                format!("{} must be a power of two ≥ 2", self.m.coarsest_level_px),
            );
        }
        Ok(())
    }

    /// Checks the batch size and the learning-rate schedule.
    fn validate_optimiser(&self) -> Result<(), crate::CortexError> {
        if self.train.batch_size == 0 {
            return invalid("train.batch_size", "must be at least 1".into());
        }
        if self.train.learning_rate.is_nan() || self.train.learning_rate <= 0.0 {
            return invalid(
                "train.learning_rate",
                format!("{} must be positive", self.train.learning_rate),
            );
        }
        let w_scale = self.train.w_learning_rate_scale;
        if !(w_scale.is_finite() && w_scale >= 0.0) {
            return invalid(
                "train.w_learning_rate_scale",
                format!("{w_scale} must be finite and ≥ 0 (0 holds W fixed)"),
            );
        }
        let floor = self.train.final_lr_fraction;
        if !(floor.is_finite() && floor > 0.0 && floor <= 1.0) {
            return invalid(
                "train.final_lr_fraction",
                format!("{floor} must be in (0, 1]"),
            );
        }
        Ok(())
    }

    /// Checks the P flow's size and the W and C buckets' guards.
    fn validate_buckets(&self) -> Result<(), crate::CortexError> {
        if self.p.mode == PMode::Flow && (self.p.couplings == 0 || self.p.hidden == 0) {
            return invalid("p", "a flow needs couplings ≥ 1 and hidden ≥ 1".into());
        }
        if !(self.w.inverse_guard.is_finite() && self.w.inverse_guard > 0.0) {
            return invalid(
                "w.inverse_guard",
                format!("{} must be finite and > 0", self.w.inverse_guard),
            );
        }
        if !(self.c.norm_eps.is_finite() && self.c.norm_eps >= 0.0) {
            return invalid(
                "c.norm_eps",
                format!("{} must be finite and ≥ 0", self.c.norm_eps),
            );
        }
        Ok(())
    }

    /// Checks the sizes that decide how much memory a run takes.
    fn validate_sizes(&self) -> Result<(), crate::CortexError> {
        let n = self.ons_size_px;
        if n > MAX_ONS_SIZE_PX {
            return invalid(
                "ons_size_px",
                format!("{n} is above the limit of {MAX_ONS_SIZE_PX}"),
            );
        }
        for (field, v) in [
            ("percept_channels", self.percept_channels),
            ("p.couplings", self.p.couplings),
            ("p.hidden", self.p.hidden),
        ] {
            if v > MAX_WIDTH {
                return invalid(field, format!("{v} is above the limit of {MAX_WIDTH}"));
            }
        }
        let b = self.train.batch_size;
        if b.saturating_mul(n * n) > MAX_BATCH_ONS_VALUES {
            return invalid(
                "train.batch_size",
                format!(
                    "{b} samples of {n}×{n} exceed the limit of {MAX_BATCH_ONS_VALUES} ONS values \
                     per frame batch (at most {} samples at this size)",
                    MAX_BATCH_ONS_VALUES / (n * n)
                ),
            );
        }
        Ok(())
    }

    /// Checks the optimiser and motion numbers (finite, in range).
    fn validate_training(&self) -> Result<(), crate::CortexError> {
        let t = &self.train;
        if !t.learning_rate.is_finite() {
            return invalid(
                "train.learning_rate",
                format!("{} must be finite", t.learning_rate),
            );
        }
        for (field, beta) in [
            ("train.adam_beta1", t.adam_beta1),
            ("train.adam_beta2", t.adam_beta2),
        ] {
            if !(0.0..1.0).contains(&beta) {
                return invalid(field, format!("{beta} must be in [0, 1)"));
            }
        }
        if !(t.adam_eps.is_finite() && t.adam_eps > 0.0) {
            return invalid(
                "train.adam_eps",
                format!("{} must be finite and > 0", t.adam_eps),
            );
        }
        let m = &self.m;
        if m.search_radius_px < 0 || m.search_radius_px as usize >= self.ons_size_px {
            return invalid(
                "m.search_radius_px",
                format!("{} must be in 0..{}", m.search_radius_px, self.ons_size_px),
            );
        }
        for (field, v) in [
            ("m.min_overlap_fraction", m.min_overlap_fraction),
            ("m.refine_fd_step_px", m.refine_fd_step_px),
            ("m.refine_max_step_px", m.refine_max_step_px),
            ("m.blur_loss_weight", m.blur_loss_weight),
            ("p.motion_ons_px_per_unit", self.p.motion_ons_px_per_unit),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return invalid(field, format!("{v} must be finite and ≥ 0"));
            }
        }
        if m.refine_stride_px == 0 {
            return invalid("m.refine_stride_px", "must be at least 1".into());
        }
        Ok(())
    }

    /// Channels of the percept: N, or 1 for the Φ = identity baseline.
    pub fn percept_dim(&self) -> usize {
        if self.baseline == Baseline::IdentityPercept {
            1
        } else {
            self.percept_channels
        }
    }
}

/// The error for an invalid `field` of the configuration, with the reason.
fn invalid(field: &str, reason: String) -> Result<(), crate::CortexError> {
    Err(crate::CortexError::InvalidConfig {
        field: field.to_string(),
        reason,
    })
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
