//! Settings of the CMF-SIM observers (see the parent module for what each step does).

use super::readout::ReadoutMode;
use crate::config::ConfigError;

/// Settings of the eye + decoder observers (`[observer]` in a run's config).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObserverSettings {
    /// Patch radius as a fraction of the field side, chosen here
    /// (docs/references.md#cmf-sim-defaults proposes 16 px of 512 = 1/32 for the paper eye; a
    /// 64-cone eye needs a relatively larger patch to hold enough cones: 1/8 is 16 px of 128,
    /// about 8 cones in radius). Every preset but `tiny` uses 1/8, the `paper` eye too (64 px of
    /// 512, about 32 cones in radius).
    pub patch_radius_fraction: f64,
    /// Mean cone spacings removed from the patch edge before reading (the lateral-inhibition
    /// fringe: the 7×7 DoG reaches 3 cones, the bulk of its surround ≈ 1.5).
    pub fringe_cones: f64,
    /// Largest single-class response to an equal-energy monochromatic test light (training
    /// white ≈ 1 after white balance; 0.5–0.8 keeps the test inside the trained range).
    pub peak_response: f64,
    /// Photon/LI noise ratio r of the renders (0: noise-free, chosen here, so that the base error
    /// compares the cortex's percepts without a noise draw; training draws r per batch).
    pub noise_ratio: f32,
    /// Largest number of shows decoded per cortex call (calls are split evenly over threads).
    pub decode_batch: usize,
    /// How a patch's percept is read: point by point in patch-relative coordinates
    /// (`"resolved"`) or its mean (`"patch-mean"`) — see [`super::readout`].
    pub readout: ReadoutMode,
    /// Distance between the resolved readout's sample points, mean cone spacings.
    pub sample_spacing_cones: f64,
    /// When set, patches keep at least this many mean cone spacings between their edge and the
    /// field's edge (a diagnostic of the lattice's rim, where the cortex is least trained);
    /// unset, the default placement keeps the whole disc plus a quarter of its radius inside
    /// the field (about 2 spacings on the quick eye).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge_clearance_cones: Option<f64>,
}

impl Default for ObserverSettings {
    fn default() -> Self {
        ObserverSettings {
            patch_radius_fraction: 0.125,
            fringe_cones: 1.5,
            peak_response: 0.6,
            noise_ratio: 0.0,
            decode_batch: 16,
            readout: ReadoutMode::Resolved,
            sample_spacing_cones: 1.0,
            edge_clearance_cones: None,
        }
    }
}

impl ObserverSettings {
    /// Every value in range (errors name the field under `observer.`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let invalid = |field: &str, reason: String| {
            Err(ConfigError::Invalid {
                field: format!("observer.{field}"),
                reason,
            })
        };
        let r = self.patch_radius_fraction;
        if !(r > 0.0 && r < 0.25) {
            return invalid(
                "patch_radius_fraction",
                format!("{r} must be in (0, 0.25): two patches must fit in the field"),
            );
        }
        if !(self.fringe_cones >= 0.0 && self.fringe_cones.is_finite()) {
            return invalid("fringe_cones", format!("{} must be ≥ 0", self.fringe_cones));
        }
        if !(self.peak_response > 0.0 && self.peak_response.is_finite()) {
            return invalid(
                "peak_response",
                format!("{} must be positive", self.peak_response),
            );
        }
        if !(self.noise_ratio >= 0.0 && self.noise_ratio.is_finite()) {
            return invalid("noise_ratio", format!("{} must be ≥ 0", self.noise_ratio));
        }
        if self.decode_batch == 0 {
            return invalid("decode_batch", "must be ≥ 1".into());
        }
        let s = self.sample_spacing_cones;
        if !(s >= 0.25 && s.is_finite()) {
            return invalid(
                "sample_spacing_cones",
                format!("{s} must be ≥ 0.25 (finer samples only repeat cones)"),
            );
        }
        if let Some(c) = self.edge_clearance_cones {
            if !(c.is_finite() && (0.0..=64.0).contains(&c)) {
                return invalid(
                    "edge_clearance_cones",
                    format!("{c} must be in [0, 64] cone spacings"),
                );
            }
        }
        Ok(())
    }
}
