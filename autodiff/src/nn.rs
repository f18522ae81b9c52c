//! Network blocks built from the tape's ops: the U-Net demosaicker and the RealNVP flow (with
//! its fused affine-coupling op).

pub mod coupling;
pub mod realnvp;
pub mod unet;
