//! # science
//!
//! What is measured of a simulated eye and the cortex trained on its optic nerve signal, as a
//! library a researcher calls from their own code — no command line, no terminal, no signal
//! handling. The command line (`colorvision`: run folders, sweeps, gather, reports) is built on
//! top of it.
//!
//! - [`config`]: every setting of a run ([`config::RunConfig`]): presets, a TOML file and
//!   `key=value` overrides, resolved and validated, errors naming the file and the field.
//! - [`source`]: the retina as the cortex's data source, the only door from the eye to the brain.
//! - [`observer`]: the black-box colour observer CMF-SIM probes — the eye followed by a decoder
//!   (the learned cortex, or one whose answer is known).
//! - [`ladder`]: CMF-SIM's calibration ladder, observers whose colour dimension is known.
//! - [`invariants`] and [`stats`]: the learned C, W and P against the eye's truth, what the eye
//!   hides, which colour directions the percept carries; the statistics behind them.
//! - [`gamut`]: how far each test light lies from the colours the eye was trained on.
//! - [`heldout`]: held-out prediction and motion errors.
//! - [`paper`]: the dimension Kotani & Ng (ICLR 2025) report for a run's settings.
//! - [`summary`]: a run's record (`summary.json`) and how its figures are written.
//! - [`verdict`]: CMF-SIM's verdict over several checkpoints of one run (settled, rising, on the
//!   border).
//!
//! Conventions: evaluation may read the eye's ground truth (cone classes, positions, the
//! lateral-inhibition kernel); nothing here feeds learning. Randomness is always seeded from the
//! run's settings. Errors are [`Error`], each naming the setting, file or stage it concerns.
//!
//! ```no_run
//! use science::config::RunConfig;
//! use science::measure::measure_observer;
//! use science::observer::ObserverKind;
//!
//! // The oracle decoder of the tiny LMS eye reads three colour dimensions.
//! let config = RunConfig::preset("tiny", "LMS")?;
//! let result = measure_observer(&config, ObserverKind::Oracle, None)?;
//! assert_eq!(result.dimension, 3);
//! # Ok::<(), science::Error>(())
//! ```

pub mod budget;
pub mod config;
mod error;
pub mod fourth;
pub mod gamut;
pub mod heldout;
pub mod invariants;
pub mod ladder;
pub mod measure;
pub mod observer;
pub mod paper;
pub mod percept_alignment;
pub mod source;
pub mod stats;
pub mod summary;
pub mod verdict;

pub use error::Error;
