//! [`RunError`]: everything that stops a command, with the file or stage it concerns, and
//! the process exit code it maps to: the errors of the eye, the cortex, CMF-SIM and the
//! settings (through [`science::Error`], in its words), the run folder's and a stop by signal.

use std::path::PathBuf;

/// Anything that stops a run, with the file or stage it concerns.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The eye, the cortex, CMF-SIM or a setting failed ([`science::Error`]: `retina: …`,
    /// `cortex: …`, `CMF-SIM: …`, or the setting's file and field).
    #[error(transparent)]
    Science(#[from] science::Error),
    /// Writing the run folder failed.
    #[error("{0}")]
    Io(#[from] crate::io::IoError),
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
    /// SIGINT/SIGTERM stopped a stage that writes nothing until it ends (scene drawing, the
    /// held-out evaluation, CMF-SIM).
    #[error("stopped by {signal} during {stage}; {next}")]
    Stopped {
        /// What stopped it.
        signal: &'static str,
        /// The stage under way.
        stage: &'static str,
        /// What was kept and how to go on.
        next: String,
    },
}

impl RunError {
    /// This error with a stop request said as one ([`RunError::Stopped`]: the signal, the
    /// stage, then `next`); any other error unchanged.
    pub fn said_as_stop(self, next: impl FnOnce() -> String) -> Self {
        let stage = match &self {
            RunError::Science(e) => e.stopped_stage(),
            _ => None,
        };
        match stage {
            Some(stage) => RunError::Stopped {
                signal: crate::interrupt::requested().unwrap_or("a stop request"),
                stage,
                next: next(),
            },
            None => self,
        }
    }

    /// A setting or option that cannot be used, naming it (`field`) and why.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        RunError::Science(science::Error::invalid(field, reason))
    }

    /// The process exit code for this error: 130 when a signal stopped the run, else 1.
    pub fn exit_code(&self) -> i32 {
        match self {
            RunError::Interrupted { .. } | RunError::Stopped { .. } => 130,
            RunError::Science(e) if e.stopped_stage().is_some() => 130,
            _ => 1,
        }
    }
}

/// The errors of the crates below, each through [`science::Error`] (the same words).
macro_rules! through_science {
    ($($error:ty),*) => {$(
        impl From<$error> for RunError {
            fn from(e: $error) -> Self {
                RunError::Science(e.into())
            }
        }
    )*};
}
through_science!(
    retina::RetinaError,
    cortex::CortexError,
    colorimetry::ColorimetryError,
    science::config::ConfigError
);
