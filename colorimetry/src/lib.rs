//! colorimetry — spectra, CIE 1931 XYZ and sRGB, cone fundamentals, CMF-SIM, Neural Scope and
//! the Stiles–Burch comparison (paper §5, S-04, RS-08).
//!
//! A leaf crate: `retina` uses it for spectra and cone sensitivities; the root package implements
//! [`Observer`] for "retina + learned cortex" and runs [`run_cmf_sim`] on it.
//!
//! | concept | module |
//! |---|---|
//! | wavelength grids, tables, embedded data | [`grid`], [`table`], [`data`], [`spectrum`] |
//! | cone sensitivities (Carroll/Neitz, Govardovskii, Stockman–Sharpe) | [`cones`] |
//! | CIE 1931 XYZ, chromaticity, daylight | [`cie`] |
//! | sRGB, linear sRGB ↔ cones (authors' code, docs/references.md#colour-transforms) | [`srgb`], [`cone_rgb`] |
//! | observer trait, analytic observers | [`observer`], [`analytic`] |
//! | matching solver, CMF-SIM, its output | [`matching`], [`cmf_sim`], [`cmf_sim_output`] |
//! | Stiles–Burch comparison, Neural Scope, hue axis and hue error | [`stiles_burch`], [`scope`], [`hue`] |
//! | SVG line plots | [`plot`] |
//!
//! Conventions: wavelengths in nm (`*_nm`), spectra as `&[f64]` on a [`WavelengthGrid`], matrices
//! row-major. User input (files, grids, settings) returns [`ColorimetryError`]; mismatched array
//! lengths inside numeric routines panic naming the routine and both lengths.

// Numeric kernels index several arrays with one loop variable, and `!(x > 0.0)` is used on
// purpose so that NaN inputs are rejected along with the out-of-range ones.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod analytic;
pub mod cie;
pub mod cmf_sim;
pub mod cmf_sim_output;
pub mod cone_rgb;
pub mod cones;
pub mod data;
pub mod error;
pub mod grid;
pub mod hue;
pub mod linalg;
pub mod matching;
pub mod observer;
pub mod plot;
pub mod scope;
pub mod spectrum;
pub mod srgb;
pub mod stiles_burch;
pub mod table;

pub use cie::CieObserver;
pub use cmf_sim::{
    run_cmf_sim, run_cmf_sim_until, run_cmf_sim_with_progress, CmfSimResult, CmfSimSettings,
};
pub use cone_rgb::ConeRgb;
pub use cones::{sensitivities, ConeClass, ConeFundamentals, ConeTemplate};
pub use error::{ColorimetryError, Result};
pub use grid::WavelengthGrid;
pub use hue::{hue_axis, hue_error, HueAxis, HueError};
pub use observer::{Observer, Show, Stimulus};
pub use scope::{NeuralScope, ScopeAccumulator};
pub use stiles_burch::{compare_stiles_burch, StilesBurchResult, StilesBurchSettings};
pub use table::SpectralTable;
