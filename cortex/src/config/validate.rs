//! Validation of a [`CortexConfig`]: every value that would otherwise panic deep inside an op,
//! or take more memory than a run can have, is an `InvalidConfig` error naming its field.

use super::*;

impl CortexConfig {
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
        if let Err((field, reason)) = self.train.validate_per_bucket() {
            return invalid(&field, reason);
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
        if let Some(a) = self.p.log_scale_bound {
            if !(a.is_finite() && a > 0.0 && a <= 20.0) {
                return invalid(
                    "p.log_scale_bound",
                    format!("{a} must be finite, > 0 and ≤ 20"),
                );
            }
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
}

/// The error for an invalid `field` of the configuration, with the reason.
fn invalid(field: &str, reason: String) -> Result<(), crate::CortexError> {
    Err(crate::CortexError::InvalidConfig {
        field: field.to_string(),
        reason,
    })
}
