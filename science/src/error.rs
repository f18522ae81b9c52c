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
}

impl Error {
    /// A setting that cannot be used, naming it (`field`) and why.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Config(crate::config::ConfigError::Invalid {
            field: field.into(),
            reason: reason.into(),
        })
    }
}
