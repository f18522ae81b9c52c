//! The crate's error type: every failure a user can cause (a config typo, a checkpoint that does
//! not match, a batch of the wrong size, a loss that became NaN) names the file or field.

use std::path::PathBuf;

/// Errors of the cortex crate. Shape mismatches between ops remain panics (programming errors).
#[derive(Debug, thiserror::Error)]
pub enum CortexError {
    #[error("unknown preset {0:?} (known: tiny, quick, sandbox, paper)")]
    UnknownPreset(String),
    #[error("invalid config field `{field}`: {reason}")]
    InvalidConfig { field: String, reason: String },
    #[error("invalid training batch, field `{field}`: {reason}")]
    InvalidBatch { field: &'static str, reason: String },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: invalid JSON metadata: {source}")]
    Json {
        path: PathBuf,
        source: serde_json::Error,
    },
    #[error("{path}: {reason}")]
    Checkpoint { path: PathBuf, reason: String },
    #[error(
        "the loss became {value} at step {step}{}; training stopped. The last good checkpoint \
         (if any) is untouched{}",
        .site.as_ref().map(|s| format!(", first produced by {s}")).unwrap_or_default(),
        .last_checkpoint.as_ref().map(|p| format!(": {}", p.display())).unwrap_or_default()
    )]
    NonFiniteLoss {
        step: u64,
        value: f64,
        /// Where the first non-finite value was made (`autodiff::NonFiniteSite`, bucket =
        /// scope), when it could be traced.
        site: Option<String>,
        last_checkpoint: Option<PathBuf>,
    },
    #[error(
        "the gradient of `{param}` became non-finite at step {step}{}; training stopped before \
         the update. The last good checkpoint (if any) is untouched{}",
        .site.as_ref().map(|s| format!(", first produced by {s}")).unwrap_or_default(),
        .last_checkpoint.as_ref().map(|p| format!(": {}", p.display())).unwrap_or_default()
    )]
    NonFiniteGradient {
        step: u64,
        /// The first parameter in id order whose gradient is non-finite.
        param: String,
        /// Where the first non-finite value was made, as for `NonFiniteLoss`.
        site: Option<String>,
        last_checkpoint: Option<PathBuf>,
    },
    #[error("data source state: {0}")]
    DataSourceState(String),
}

impl CortexError {
    /// Wraps an I/O error with its path.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        CortexError::Io {
            path: path.into(),
            source,
        }
    }
}

impl From<optic_nerve::BatchError> for CortexError {
    fn from(e: optic_nerve::BatchError) -> Self {
        CortexError::InvalidBatch {
            field: e.field,
            reason: e.reason,
        }
    }
}
