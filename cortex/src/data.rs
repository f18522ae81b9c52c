//! What the cortex receives: [`OnsBatch`] (crate `optic_nerve`, the one batch type from the eye
//! to the tape: optic-nerve pairs and, only when a run asks for it, the oracle motion; layout
//! and motion convention in its docs), drawn from a [`DataSource`]. Nothing else from the eye
//! enters (no scene, no cone types, no positions).

use crate::CortexError;
pub use optic_nerve::OnsBatch;

/// A stream of training batches. The root package implements it with the retina; the cortex
/// crate ships [`crate::synthetic::SyntheticSource`] for tests and benches.
///
/// For exact resume, a source may expose its state (its RNG, its position in a dataset):
/// [`crate::Trainer`] stores it in checkpoints and restores it on resume.
pub trait DataSource {
    /// Fills `out` with the next batch of `batch_size` pairs, reusing its buffers (a training
    /// loop keeps one batch and refills it: no allocation per step).
    fn next_batch_into(&mut self, batch_size: usize, out: &mut OnsBatch);

    /// The next batch of `batch_size` pairs, freshly allocated.
    fn next_batch(&mut self, batch_size: usize) -> OnsBatch {
        let mut out = OnsBatch::default();
        self.next_batch_into(batch_size, &mut out);
        out
    }

    /// The source's resumable state, if it has one.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }

    /// Restores a state returned by [`DataSource::save_state`].
    fn load_state(&mut self, _state: &serde_json::Value) -> Result<(), CortexError> {
        Ok(())
    }
}
