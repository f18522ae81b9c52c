//! D, the demosaicker (authors' code, docs/references.md#d-bucket; paper S-03 "Learning ... Interpolation D"): the U-Net of
//! `autodiff::nn::unet`, N channels in and out, no residual; or the identity (the S-05 baseline
//! "no demosaicker").
//!
//! Shapes: `(B, N, n, n) → (B, N, n, n)`. Parameters under `d.` (see the U-Net docs); each
//! block of the U-Net is recorded in its own scope under D (`D.inc`, `D.down1`, …), each
//! layer tagged by its parameter name.

use crate::config::{CortexConfig, DMode};
use autodiff::nn::unet::{OutputBox, UNet, UNetConfig};
use autodiff::{Float, ParamStore, Tape, Var};

/// The D bucket.
#[derive(Clone, Debug)]
pub enum DBucket {
    /// The U-Net.
    UNet(UNet),
    /// D = identity.
    Identity,
}

impl DBucket {
    /// Adds the U-Net's parameters (seeded from `train.seed`) unless D is the identity.
    pub fn new<T: Float>(params: &mut ParamStore<T>, cfg: &CortexConfig) -> Self {
        match Self::unet_config(cfg) {
            None => DBucket::Identity,
            Some(uc) => DBucket::UNet(UNet::new(params, "d", uc).with_block_scopes("D")),
        }
    }

    /// The U-Net's shapes and seed that `cfg` asks for (`None`: D is the identity).
    pub fn unet_config(cfg: &CortexConfig) -> Option<UNetConfig> {
        match cfg.d.mode {
            DMode::Identity => None,
            DMode::UNet => Some(UNetConfig {
                in_channels: cfg.percept_channels,
                out_channels: cfg.percept_channels,
                widths: cfg.d.widths.clone(),
                seed: cfg.train.seed,
            }),
        }
    }

    /// Records D on the tape.
    pub fn forward<T: Float>(&self, tape: &mut Tape<T>, params: &ParamStore<T>, x: Var) -> Var {
        self.forward_blocks(tape, params, x).0
    }

    /// Records D's outputs in `out_box` alone (`autodiff::nn::unet` window docs): the
    /// U-Net's up blocks run only where those outputs reach; the identity is cut to the box.
    pub fn forward_box<T: Float>(
        &self,
        tape: &mut Tape<T>,
        params: &ParamStore<T>,
        x: Var,
        out_box: OutputBox,
    ) -> Var {
        match self {
            DBucket::UNet(net) => net.forward_box(tape, params, x, out_box),
            DBucket::Identity => out_box.crop(tape, x),
        }
    }

    /// Records D on the tape; returns its output and each block's (none for the identity).
    pub fn forward_blocks<T: Float>(
        &self,
        tape: &mut Tape<T>,
        params: &ParamStore<T>,
        x: Var,
    ) -> (Var, Vec<Var>) {
        match self {
            DBucket::UNet(net) => {
                let a = net.forward_blocks(tape, params, x);
                (a.output, a.blocks)
            }
            DBucket::Identity => (x, Vec::new()),
        }
    }
}
