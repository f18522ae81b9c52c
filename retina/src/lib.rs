//! retina — the spectral eye simulation, from scene to optic nerve signal (paper S-02;
//! authors' code, docs/references.md#retina-data-flow).
//!
//! Stages, one noun and one `compute` each (inputs, outputs, shapes and units in each module):
//!
//! | stage | module | in → out |
//! |---|---|---|
//! | scenes | [`scene`] | dead leaves / EXR / RGB / tetra → spectral radiance `(λ, h, w)` |
//! | projection | [`scene::projection`] | spectra → class planes `(k, h, w)`, once per tile |
//! | pool | [`scene::pool`] | tiles of class planes as mip stacks `(levels, planes, t, t)` |
//! | eye motion | [`eye_motion`] | integer shift `[dx, dy]` ∈ [−M, M−1]², the oracle |
//! | mosaic | [`mosaic`] | spec string → per-cell class weights `(n·n, k)` |
//! | foveation | [`foveation`] | cone positions `(n·n)` in field px; mip-mapped sampling |
//! | cones | [`cones`] | class planes → activations `(n, n)`; photon noise |
//! | lateral inhibition | [`lateral_inhibition`] | activations → bipolar `(n, n)`; 1 % noise |
//! | spikes (optional) | [`spikes`], [`movie`] | bipolar → ON/OFF LIF spikes, time averages |
//! | the eye | [`retina`] | [`Retina::batch`] → [`EyeBatch`]: the signal [`OnsBatch`] `(B, 2, n, n)` + the [`BatchTruth`] it keeps (oracle shift, tiles, origins) |
//! | pictures | [`pictures`] | PNGs of every stage, ONS under eye motion |
//! | stimuli | [`stimulus`] | a disc of light on black → activations and ONS (psychophysics) |
//!
//! Conventions: arrays are row-major f32 (`(n, n)` lattice arrays are indexed `[row·n + col]`,
//! lattice row i / column j); positions are `[x, y]` = `[column, row]` in pixels of the
//! `field_px`² scene field; wavelengths in nm; cone excitations dimensionless (≈ 1 for the sRGB
//! white after white balance). Every number is a config value ([`RetinaConfig`], presets `tiny`,
//! `quick`, `sandbox`, `paper`) with its unit in its name and its source in its doc comment.
//! Outside input returns [`RetinaError`] naming the file or setting; buffer-shape mismatches
//! between stages panic naming the stage and both shapes.

// Index loops over wavelengths, classes and pixels mirror the formulas in the docs.
#![allow(clippy::needless_range_loop)]

pub mod analysis;
pub mod cones;
pub mod config;
pub mod error;
pub mod eye_motion;
pub mod foveation;
pub mod lateral_inhibition;
pub mod mosaic;
pub mod movie;
pub mod pictures;
pub mod retina;
pub mod scene;
pub mod spikes;
pub mod stimulus;

pub use config::RetinaConfig;
pub use error::{Result, RetinaError};
pub use mosaic::{Mosaic, MosaicSpec};
pub use movie::{Movie, MovieConfig, SpikeTrain};
pub use pictures::write_stage_pictures;
pub use retina::{BatchTruth, EyeBatch, OnsBatch, Retina, SharedTile};
pub use scene::SpectralImage;
pub use stimulus::{Disc, NoiseDraw};
