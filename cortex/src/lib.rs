//! # cortex — learning to see from the optic nerve signal alone
//!
//! The cortical model of Kotani & Ng (ICLR 2025, paper §4 and S-03; official code described in
//! `official-implementation.md` §3), on the `autodiff` tape. It receives optic-nerve arrays and,
//! only when a run asks for it, the oracle eye motion ([`TrainingBatch`]); it never depends on
//! the retina crate.
pub mod buckets;
pub mod checkpoint;
pub mod config;
pub mod data;
pub mod error;
pub mod eval;
pub mod model;
pub mod motion;
pub mod persist;
pub mod rng;
pub mod scope;
pub mod synthetic;
pub mod trainer;

pub use config::CortexConfig;
pub use data::{DataSource, TrainingBatch};
pub use error::CortexError;
pub use model::Cortex;
pub use trainer::{PredictionError, StepStats, Trainer};
