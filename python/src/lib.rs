//! `colorvision._native`: the Rust side of the `colorvision` Python package (see
//! `docs/python.md`). The eye ([`eye::Eye`]) hands its optic nerve signal (ONS) to Python as
//! NumPy arrays; CMF-SIM ([`measure::cmf_sim`]) measures any decoder — a Python callable, a
//! known-answer decoder or a trained run's cortex — and [`held_out::hidden`] which cone classes'
//! own signals its percept carries ([`held_out::own_image`]: as a picture).
//!
//! Conventions (the same as the Rust crates'):
//! - An ONS frame is `(n, n)` float32 on the cone lattice: row = lattice row (top to bottom),
//!   column = lattice column (left to right); a batch of frames is `(N, n, n)`.
//! - A percept batch is `(N, C, n, n)` float32: C channels on the same lattice.
//! - Positions are field pixels `[x, y]`, x to the right, y down, the field's top-left at
//!   `[0, 0]`; an eye shift is `[dx, dy] / (field_px / 2)`.
//!
//! Threads: Rust works with the GIL released; Python (a decoder, a progress callback) is
//! called only on the thread that called in, never from Rust's worker threads
//! ([`beside::run_beside_python`]), and Python's signals are checked every
//! [`beside::POLL_MS`] ms, so Ctrl-C raises `KeyboardInterrupt` within about a second.

use pyo3::prelude::*;

pub mod arrays;
pub mod beside;
pub mod decoders;
pub mod errors;
pub mod eye;
pub mod held_out;
pub mod measure;
pub mod result;
pub mod settings;

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<eye::Eye>()?;
    m.add_class::<eye::Batches>()?;
    m.add_class::<decoders::KnownDecoder>()?;
    m.add_class::<decoders::Run>()?;
    m.add_class::<result::CmfSimResult>()?;
    m.add_function(wrap_pyfunction!(decoders::load_run, m)?)?;
    m.add_function(wrap_pyfunction!(measure::cmf_sim, m)?)?;
    m.add_function(wrap_pyfunction!(held_out::hidden, m)?)?;
    m.add_function(wrap_pyfunction!(held_out::own_image, m)?)?;
    Ok(())
}
