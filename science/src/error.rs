//! [`Error`]: what stops a measurement, with the setting or stage it concerns.

/// Anything that stops building an eye, a cortex or a measurement.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The retina could not be built.
    #[error("retina: {0}")]
    Retina(#[from] retina::RetinaError),
    /// The cortex failed (a non-finite loss names the step and the last good checkpoint).
    #[error("cortex: {0}")]
    Cortex(#[from] cortex::CortexError),
    /// CMF-SIM failed.
    #[error("CMF-SIM: {0}")]
    Colorimetry(#[from] colorimetry::ColorimetryError),
    /// A setting is wrong.
    #[error("{0}")]
    Config(#[from] crate::config::ConfigError),
    /// A stop was requested (the caller's stop flag was set) during `stage`.
    #[error("stopped on request during {stage}")]
    Stopped {
        /// What was under way.
        stage: &'static str,
    },
}

impl Error {
    /// The stage a stop request ended, when this error is one: scene drawing, the held-out
    /// evaluation or CMF-SIM.
    pub fn stopped_stage(&self) -> Option<&'static str> {
        match self {
            Error::Stopped { stage } => Some(stage),
            Error::Retina(retina::RetinaError::Stopped) => Some("scene generation"),
            Error::Colorimetry(colorimetry::ColorimetryError::Stopped) => Some("CMF-SIM"),
            _ => None,
        }
    }

    /// A setting that cannot be used, naming it (`field`) and why.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Config(crate::config::ConfigError::Invalid {
            field: field.into(),
            reason: reason.into(),
        })
    }
}
