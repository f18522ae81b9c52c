//! Rust errors as Python exceptions: a bad setting, file or array is a `ValueError` with the
//! one-line message the command line prints after `colorvision: error: `; a stop request is
//! `KeyboardInterrupt`; a panic (a bug, never bad input) is a `RuntimeError`.

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::PyErr;

/// A `ValueError` with the command line's one-line wording.
pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(science::config::shortened(&e.to_string()))
}

/// A science error: a stop is `KeyboardInterrupt`, everything else a `ValueError`.
pub fn science_error(e: science::Error) -> PyErr {
    match e.stopped_stage() {
        Some(stage) => PyKeyboardInterrupt::new_err(format!("stopped during {stage}")),
        None => value_error(e),
    }
}

/// A run-folder error (the same words as `colorvision cmf-sim --run DIR`).
pub fn run_error(e: colorvision::run::RunError) -> PyErr {
    match e {
        colorvision::run::RunError::Science(e) => science_error(e),
        e => value_error(e),
    }
}

/// A panic caught at the boundary: Python gets an exception, never an abort.
pub fn panic_error(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let why = payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".into());
    PyRuntimeError::new_err(format!("colorvision internal error (please report): {why}"))
}
