//! # cortex — learning to see from the optic nerve signal alone
//!
//! The cortical model of Kotani & Ng (ICLR 2025, paper §4 and S-03; official code described in
//! authors' code, docs/references.md#cortex-pipeline), on the `autodiff` tape. It receives optic-nerve arrays and,
//! only when a run asks for it, the oracle eye motion ([`OnsBatch`], from the dependency-free
//! `optic_nerve` crate the eye writes into); it never depends on the retina crate.
//!
//! ## Using it (the root package)
//! - [`CortexConfig::preset`] (`tiny`, `quick`, `sandbox`, `paper`), every number a TOML value.
//! - Implement [`DataSource`] with the retina (`next_batch_into`, and `save_state`/`load_state`
//!   for exact resume). The S-05 baseline "cone activations as ONS" is
//!   `config.baseline == Baseline::ConeActivationsAsOns`: the data source must then deliver
//!   cone activations instead of laterally inhibited signals.
//! - [`Trainer::new`], [`Trainer::step`] → [`StepStats`] (loss, per-bucket timings),
//!   [`Trainer::run`] (periodic atomic checkpoints), [`Trainer::save_checkpoint`],
//!   [`Trainer::resume`] (bit-identical), [`Trainer::continue_from`] (gene therapy / boosting:
//!   same cortex, new data, fresh Adam), [`checkpoint::latest_checkpoint`].
//! - Evaluation: [`Trainer::prediction_error`] (vs "next = current"),
//!   [`Trainer::motion_error_ons_px`], [`Cortex::decode_frames`], [`Cortex::record_decode_windows`]
//!   (D on the window a few cells need), [`Cortex::learned_c`],
//!   [`Cortex::learned_positions`], [`Cortex::learned_w_kernel`]; the percepts of the last step
//!   ([`Trainer::last_percept`]) for a Neural Scope fitted by the caller, who knows the scene
//!   (`colorimetry::NeuralScope`; the cortex never learns from it).
//! - [`synthetic::SyntheticSource`]: a retina-free stand-in for tests and benches.

pub mod buckets;
pub mod checkpoint;
pub mod config;
pub mod credit;
pub mod data;
pub mod error;
pub mod eval;
pub mod forward_forward;
pub mod model;
pub mod optimizer;
pub mod persist;
pub mod rng;
pub mod rule;
pub mod synthetic;
pub mod trainer;
pub mod window;

pub use autodiff::nn::unet::OutputBox;
pub use config::CortexConfig;
pub use data::{DataSource, OnsBatch};
pub use error::CortexError;
pub use eval::MotionError;
pub use model::Cortex;
pub use rule::{RuleContext, RuleEntry, RuleName, RuleSettings};
pub use trainer::{PredictionError, StepStats, Trainer};
pub use window::Window;
