//! Network blocks built from the tape's ops: the U-Net demosaicker and the RealNVP flow.

pub mod realnvp;
pub mod unet;
