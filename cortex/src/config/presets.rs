//! The five presets of [`CortexConfig`] (`tiny`, `quick`, `large`, `sandbox`, `paper`; see the
//! parent module's docs), each default citing its source.

use super::train::default_final_lr_fraction;
use super::*;

/// [`PConfig::log_scale_bound`] of every preset.
pub const DEFAULT_LOG_SCALE_BOUND: f64 = 2.0;

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
                log_scale_bound: Some(DEFAULT_LOG_SCALE_BOUND),
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
            loss: LossConfig {
                border_px: 3,
                outside_field_weight: 0.0,
            },
            train: TrainConfig {
                batch_size: 8,
                learning_rate: 1e-3,
                optimizer: OptimizerName::Adam,
                sgd_momentum: 0.9,
                adam_beta1: 0.9,
                adam_beta2: 0.999,
                adam_eps: 1e-8,
                seed: 1234,
                steps: 100_000,
                checkpoint_every_steps: 1000,
                w_learning_rate_scale: 1.0,
                lr_schedule: LrSchedule::Constant,
                final_lr_fraction: default_final_lr_fraction(),
                clip_global_norm: None,
                alignment_every_steps: 100,
                per_bucket: PerBucketTrain::default(),
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

    /// The quick cortex on the `large` eye's 128×128 ONS: the same U-Net (16/32/64), so each
    /// receptive field spans as many cone spacings as in `quick`; the motion unit scales with
    /// the field (64 px, as `quick`'s 32 px of 64 and `paper`'s 128 of 256).
    pub fn large() -> Self {
        let mut c = Self::quick();
        c.ons_size_px = 128;
        c.p.motion_ons_px_per_unit = 64.0;
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
            "large" => Ok(Self::large()),
            "sandbox" => Ok(Self::sandbox()),
            "paper" => Ok(Self::paper()),
            other => Err(crate::CortexError::UnknownPreset(other.to_string())),
        }
    }
}
