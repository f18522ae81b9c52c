//! retina — the spectral eye simulation (paper S-02; official §2; SPEC §3).

pub mod analysis;
pub mod cones;
pub mod error;
pub mod eye_motion;
pub mod foveation;
pub mod lateral_inhibition;
pub mod mosaic;
pub mod scene;
pub mod spikes;

pub use error::{Result, RetinaError};
