//! The crate's error type.
//!
//! Every error that can come from user input (a CSV file, a wavelength grid, a settings value)
//! names what was being read and where: the file (or table name), the line and the field.
//! Programming errors inside the crate (two arrays of different length handed to a numeric
//! routine) panic instead, naming the routine and both lengths.

use std::path::PathBuf;

/// Errors returned by `colorimetry`.
#[derive(Debug, thiserror::Error)]
pub enum ColorimetryError {
    /// A spectral or key/value table could not be parsed.
    #[error("{file}: line {line}, field `{field}`: {message}")]
    Parse {
        /// Table name or file path.
        file: String,
        /// 1-based line number in the text.
        line: usize,
        /// Column name (or `header`) of the offending field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A named column does not exist.
    #[error("table `{table}` has no column `{column}` (columns: {available})")]
    MissingColumn {
        /// Table name.
        table: String,
        /// The requested column.
        column: String,
        /// Comma-separated list of the columns that exist.
        available: String,
    },
    /// A wavelength (or grid) lies outside the table's wavelength range.
    #[error(
        "table `{table}` covers {table_min_nm}–{table_max_nm} nm, which does not cover \
         the requested {requested_min_nm}–{requested_max_nm} nm"
    )]
    NotCovered {
        /// Table name.
        table: String,
        /// The table's first wavelength.
        table_min_nm: f64,
        /// The table's last wavelength.
        table_max_nm: f64,
        /// Smallest requested wavelength.
        requested_min_nm: f64,
        /// Largest requested wavelength.
        requested_max_nm: f64,
    },
    /// An invalid wavelength grid.
    #[error("invalid wavelength grid: {0}")]
    InvalidGrid(String),
    /// An invalid setting or argument (names the setting).
    #[error("invalid `{name}`: {message}")]
    InvalidSetting {
        /// The setting or argument.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A stop was requested (the caller's stop flag was set) before the measurement ended.
    #[error("stopped on request before the measurement ended")]
    Stopped,
    /// JSON (de)serialisation failed.
    #[error("{}: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The serde error.
        #[source]
        source: serde_json::Error,
    },
}

/// Shorthand for `Result<T, ColorimetryError>`.
pub type Result<T> = std::result::Result<T, ColorimetryError>;

impl ColorimetryError {
    /// An [`ColorimetryError::InvalidSetting`] with the given name and message.
    pub fn setting(name: impl Into<String>, message: impl Into<String>) -> Self {
        ColorimetryError::InvalidSetting {
            name: name.into(),
            message: message.into(),
        }
    }
}

impl From<atomic_io::FileError> for ColorimetryError {
    fn from(e: atomic_io::FileError) -> Self {
        ColorimetryError::Io {
            path: e.path,
            source: e.source,
        }
    }
}
