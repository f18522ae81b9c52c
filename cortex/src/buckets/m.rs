//! M, eye-motion estimation (authors' code, docs/references.md#motion-estimation; paper S-03): the oracle, the official pyramid block
//! matching, and a learned sub-pixel estimator. Estimation runs without gradients; the learned
//! estimator adds a blurred objective through which P learns.
//!
//! Units: a motion `[dx, dy]` is in the flow's visual-field units (`xy = P(uv)`, with the ONS
//! grid `uv ∈ [−1, 1]²`, align-corners); x is the column axis. Sign: frame t+1 at p shows
//! frame t at p + d.

pub mod block_matching;
pub mod blur;
pub mod gauge;
pub mod learned;
pub mod sampling;

/// The cell-position map P evaluated in plain f64, without a tape: what M needs to de-warp.
pub trait PlainFlow: Sync {
    /// `uv → xy` in place.
    fn forward(&self, pts: &mut [[f64; 2]]);
    /// `xy → uv` in place.
    fn inverse(&self, pts: &mut [[f64; 2]]);
}

/// P = identity.
pub struct IdentityFlow;

impl PlainFlow for IdentityFlow {
    fn forward(&self, _pts: &mut [[f64; 2]]) {}
    fn inverse(&self, _pts: &mut [[f64; 2]]) {}
}
