//! retina — the spectral eye simulation (paper S-02; official §2; SPEC §3).

pub mod analysis;
pub mod cones;
pub mod config;
pub mod error;
pub mod eye_motion;
pub mod foveation;
pub mod lateral_inhibition;
pub mod mosaic;
pub mod pictures;
pub mod movie;
pub mod retina;
pub mod scene;
pub mod spikes;

pub use config::RetinaConfig;
pub use error::{Result, RetinaError};
pub use movie::{Movie, MovieConfig, SpikeTrain};
pub use pictures::write_stage_pictures;
pub use retina::{OnsBatch, Retina};
