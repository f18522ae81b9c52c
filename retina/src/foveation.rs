//! Foveation: where the cones are ([`layout`], built on the radial [`density`] profile and
//! [`perlin`] jitter), and how they sample the scene ([`sampler`]).

pub mod density;
pub mod layout;
pub mod perlin;
pub mod sampler;

pub use density::{RadialDensity, RadialMap};
pub use layout::{ConeLayout, FoveationConfig, JitterConfig, LayoutConfig};
pub use sampler::{ConeSampler, MipStack};
