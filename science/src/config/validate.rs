//! Validation of a resolved [`RunConfig`]: the values that must agree across the retina, the
//! cortex and CMF-SIM, each error naming its field.

use super::*;

impl RunConfig {
    /// Checks values that must agree across components.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let invalid = |field: &str, reason: String| ConfigError::Invalid {
            field: field.into(),
            reason,
        };
        self.validate_integers()?;
        self.validate_ranges()?;
        self.validate_said_twice()?;
        if self.retina.cones_per_side != self.cortex.ons_size_px {
            return Err(invalid(
                "cortex.ons_size_px",
                format!(
                    "{} but the retina has {} cones per side",
                    self.cortex.ons_size_px, self.retina.cones_per_side
                ),
            ));
        }
        self.retina.validate().map_err(|e| match e {
            retina::RetinaError::InvalidSetting { name, message } => {
                invalid(&format!("retina.{name}"), message)
            }
            other => invalid("retina", other.to_string()),
        })?;
        self.cortex.validate().map_err(|e| match e {
            cortex::CortexError::InvalidConfig { field, reason } => {
                invalid(&format!("cortex.{field}"), reason)
            }
            other => invalid("cortex", other.to_string()),
        })?;
        cortex::rule::check(&self.learning_rule, &self.rule).map_err(|e| match e {
            cortex::CortexError::InvalidConfig { field, reason } => invalid(&field, reason),
            other => invalid("learning_rule", other.to_string()),
        })?;
        if self.steps == 0 {
            return Err(invalid("steps", "must be at least 1".into()));
        }
        self.observer.validate()?;
        let grid = self
            .retina
            .grid
            .grid()
            .map_err(|e| invalid("retina.grid", e.to_string()))?;
        for (what, s) in [
            ("cmf_sim", self.cmf_sim.clone()),
            ("schedule.checkpoint_cmf", self.cmf_settings(false)),
        ] {
            colorimetry::cmf_sim::validate_settings(&s, &grid).map_err(|e| match e {
                colorimetry::ColorimetryError::InvalidSetting { name, message } => {
                    invalid(&format!("{what}.{name}"), message)
                }
                other => invalid(what, other.to_string()),
            })?;
        }
        Ok(())
    }

    /// Checks that every integer fits config.toml, whose integers are signed 64-bit.
    fn validate_integers(&self) -> Result<(), ConfigError> {
        let invalid = |field: &str, reason: String| ConfigError::Invalid {
            field: field.into(),
            reason,
        };
        for (field, v) in [
            ("seed", self.seed),
            ("steps", self.steps),
            ("retina.mosaic_seed", self.retina.mosaic_seed),
            ("retina.layout_seed", self.retina.layout_seed),
            ("retina.scene_seed", self.retina.scene_seed),
            ("cortex.train.seed", self.cortex.train.seed),
            ("cmf_sim.seed", self.cmf_sim.seed),
        ] {
            if v > i64::MAX as u64 {
                return Err(invalid(
                    field,
                    format!("{v} exceeds {} (TOML integers are signed 64-bit)", i64::MAX),
                ));
            }
        }
        Ok(())
    }

    /// Checks that settings said in two places agree (`oracle_motion` and `[cortex.m] mode`,
    /// `steps` and `[cortex.train] steps`, `cones` and `[retina] cones`) and that the mosaic
    /// parses.
    fn validate_said_twice(&self) -> Result<(), ConfigError> {
        let invalid = |field: &str, reason: String| ConfigError::Invalid {
            field: field.into(),
            reason,
        };
        if self.oracle_motion != (self.cortex.m.mode == cortex::config::MMode::Oracle) {
            return Err(invalid(
                "oracle_motion",
                format!(
                    "{} but [cortex.m] mode = {:?}: the oracle motion is mode \"oracle\"",
                    self.oracle_motion, self.cortex.m.mode
                ),
            ));
        }
        if self.cortex.train.steps != self.steps {
            return Err(invalid(
                "cortex.train.steps",
                format!(
                    "{} disagrees with `steps` = {} (they are one setting)",
                    self.cortex.train.steps, self.steps
                ),
            ));
        }
        if self.retina.cones != self.cones {
            return Err(invalid(
                "retina.cones",
                format!(
                    "`{}` disagrees with `cones` = `{}`",
                    self.retina.cones, self.cones
                ),
            ));
        }
        retina::MosaicSpec::parse(&self.cones).map_err(|e| match e {
            retina::RetinaError::InvalidSetting { message, .. } => {
                invalid("cones", format!("`{}`: {message}", self.cones))
            }
            other => invalid("cones", other.to_string()),
        })?;
        Ok(())
    }
}
