//! P's flow from its shapes: `cortex.p.couplings` blocks of `1 → H → H → 2` (H =
//! `cortex.p.hidden`), `H² + 5H + 2` parameters each (`autodiff::nn::realnvp`), which at the top
//! of H's range outweigh the rest of the cortex.
//!
//! Copies of the parameters a training run holds at once (a heap profile of a run at the top of
//! H, docs/memory-tops.md): the store (1), Adam's two moments (2), and the tape kept from step to
//! step — a leaf copy of each parameter (1), each leaf's gradient slot (1), the gradient
//! container's copy (1). Besides these, during a step the copy each coupling op saves for
//! backward, forward and inverse (2); at the run's end, in their place, the tape-free flow in
//! f64 that places the pictures' learned positions (2). The checkpoint streams its files and
//! holds no copy. And backward keeps one partial gradient of a coupling per block of
//! `autodiff::nn::coupling::BLOCK` points of the warp's inverse (batch × ONS pixels).

use crate::config::RunConfig;
use cortex::config::PMode;

/// Whole copies of P's parameters (module docs).
const COPIES: f64 = 10.0;

/// Bytes of P's flow parameters and their copies in a training run of `config` (0 when P is
/// not a learned flow).
pub fn bytes(config: &RunConfig) -> f64 {
    let p = &config.cortex.p;
    if p.mode != PMode::Flow {
        return 0.0;
    }
    let h = p.hidden as f64;
    let per_coupling = (h * h + 5.0 * h + 2.0) * 4.0;
    let params = p.couplings as f64 * per_coupling;
    let points = config.cortex.train.batch_size as f64 * (config.cortex.ons_size_px as f64).powi(2);
    let partials = (points / autodiff::nn::coupling::BLOCK as f64).ceil() * per_coupling;
    COPIES * params + partials
}
