//! The crate's error type.
//!
//! Everything that comes from outside the program (a scene file, an image, a mosaic string, a
//! configuration value) returns [`RetinaError`], and every variant names the file or setting and
//! says what is wrong. Programming errors (buffers of the wrong length handed between stages)
//! panic instead, naming the stage and both shapes.

use std::path::PathBuf;

/// Errors returned by `retina`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RetinaError {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An OpenEXR file is truncated, corrupt or not an EXR file.
    #[error("{}: not a readable OpenEXR file ({message})", path.display())]
    Exr {
        /// The file.
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// A scene file's radiance is not finite and non-negative.
    #[error("{}: {message}", path.display())]
    Radiance {
        /// The file.
        path: PathBuf,
        /// The first bad pixel and its value.
        message: String,
    },
    /// A spectral scene file (MATLAB v7.3 `.mat`, HDF5) is not readable, or its content is not
    /// a spectral cube: the message says which (not HDF5, no cube dataset, wrong shape, …).
    #[error("{}: {message}", path.display())]
    SceneFile {
        /// The file.
        path: PathBuf,
        /// What is wrong, on one line.
        message: String,
    },
    /// A stop was requested (the caller's stop flag was set) while the scenes were drawn.
    #[error("stopped on request while the scenes were drawn")]
    Stopped,
    /// An OpenEXR file has no channel whose name carries a wavelength.
    #[error(
        "{}: no wavelength channels (expected names like `wl_550nm` or `S0.550,0nm`; \
         found: {found})",
        path.display()
    )]
    NoWavelengthChannels {
        /// The file.
        path: PathBuf,
        /// The channel names that were found.
        found: String,
    },
    /// A spectral scene's wavelengths do not cover the range the cone sensitivities need.
    #[error(
        "{source_name}: wavelengths {have_min_nm}–{have_max_nm} nm do not cover the \
         {need_min_nm}–{need_max_nm} nm of the cone sensitivities"
    )]
    GridNotCovering {
        /// The file (or scene name).
        source_name: String,
        /// First wavelength of the scene.
        have_min_nm: f64,
        /// Last wavelength of the scene.
        have_max_nm: f64,
        /// First wavelength needed.
        need_min_nm: f64,
        /// Last wavelength needed.
        need_max_nm: f64,
    },
    /// A PNG image could not be decoded or encoded.
    #[error("{}: {message}", path.display())]
    Png {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// An invalid setting (mosaic string, preset name, configuration value).
    #[error("invalid `{name}`: {message}")]
    InvalidSetting {
        /// The setting.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// An error from the colorimetry crate (tables, sensitivities).
    #[error(transparent)]
    Colorimetry(#[from] colorimetry::ColorimetryError),
}

/// Shorthand for `Result<T, RetinaError>`.
pub type Result<T> = std::result::Result<T, RetinaError>;

impl RetinaError {
    /// An [`RetinaError::InvalidSetting`] with the given name and message.
    pub fn setting(name: impl Into<String>, message: impl Into<String>) -> Self {
        RetinaError::InvalidSetting {
            name: name.into(),
            message: message.into(),
        }
    }

    /// A [`RetinaError::SceneFile`] for `path`; the message is folded onto one line.
    pub fn scene_file(path: impl Into<PathBuf>, message: impl AsRef<str>) -> Self {
        RetinaError::SceneFile {
            path: path.into(),
            message: message
                .as_ref()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" "),
        }
    }

    /// An [`RetinaError::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        RetinaError::Io {
            path: path.into(),
            source,
        }
    }
}

impl From<atomic_io::FileError> for RetinaError {
    fn from(e: atomic_io::FileError) -> Self {
        RetinaError::io(e.path, e.source)
    }
}
