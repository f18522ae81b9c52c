//! [`RunError`]: everything that stops a command, with the file or stage it concerns, and
//! the process exit code it maps to. Its own module so that the run folder, pictures, reports
//! and commands name it without depending on the training loop ([`crate::run`]).

use std::path::PathBuf;

/// Anything that stops a run, with the file or stage it concerns.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The retina could not be built.
    #[error("retina: {0}")]
    Retina(#[from] retina::RetinaError),
    /// Training failed (a non-finite loss names the step and the last good checkpoint).
    #[error("cortex: {0}")]
    Cortex(#[from] cortex::CortexError),
    /// CMF-SIM failed.
    #[error("CMF-SIM: {0}")]
    Colorimetry(#[from] colorimetry::ColorimetryError),
    /// Writing the run folder failed.
    #[error("{0}")]
    Io(#[from] crate::io::IoError),
    /// A setting is wrong.
    #[error("{0}")]
    Config(#[from] crate::config::ConfigError),
    /// The run folder cannot be used for this run.
    #[error("{path}: {reason}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// SIGINT/SIGTERM stopped the run after a step; a checkpoint was written.
    #[error(
        "stopped by {signal} after step {step} of {steps}; checkpoint {checkpoint}. Continue \
         with `colorvision resume {run}` (or the same command with --resume)",
        checkpoint = .checkpoint.display(),
        run = .run.display()
    )]
    Interrupted {
        /// What stopped it.
        signal: &'static str,
        /// Steps done.
        step: u64,
        /// Steps of the run.
        steps: u64,
        /// The checkpoint written.
        checkpoint: PathBuf,
        /// The run folder it belongs to.
        run: PathBuf,
    },
}

impl RunError {
    /// A setting or option that cannot be used, naming it (`field`) and why.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        RunError::Config(crate::config::ConfigError::Invalid {
            field: field.into(),
            reason: reason.into(),
        })
    }

    /// The process exit code for this error: 130 when a signal stopped the run, else 1.
    pub fn exit_code(&self) -> i32 {
        match self {
            RunError::Interrupted { .. } => 130,
            _ => 1,
        }
    }
}
