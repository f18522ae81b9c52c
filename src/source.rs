//! The retina as the cortex's data source: the only door between the eye and the brain.
//!
//! [`RetinaSource`] turns each [`retina::OnsBatch`] into a [`cortex::TrainingBatch`] that carries
//! the ONS pairs and — only when the run asks for it (`oracle_motion = true`) — the true eye
//! shift. Scene pixels, cone types, positions and the lateral-inhibition kernel stay behind.
//!
//! Determinism: batch k is drawn with an RNG seeded from `(seed, k)`, so the source's whole state
//! is the number of batches drawn; resuming replays that many batches to rebuild the scene
//! pool's refresh state exactly.

use cortex::{CortexError, DataSource, TrainingBatch};
use rand::rngs::SmallRng;
use rand::SeedableRng;
use retina::{OnsBatch, Retina};

/// Feeds a cortex from a simulated eye.
pub struct RetinaSource {
    /// The eye (ground truth stays here; the cortex never receives it).
    pub retina: Retina,
    seed: u64,
    batches: u64,
    oracle_motion: bool,
    buffer: OnsBatch,
}

impl RetinaSource {
    /// A source drawing batches from `retina` with `seed`; `oracle_motion` passes the true shift.
    pub fn new(retina: Retina, seed: u64, oracle_motion: bool) -> Self {
        RetinaSource {
            retina,
            seed,
            batches: 0,
            oracle_motion,
            buffer: OnsBatch::default(),
        }
    }

    /// Number of batches drawn so far.
    pub fn batches_drawn(&self) -> u64 {
        self.batches
    }

    /// Whether batches carry the oracle motion.
    pub fn oracle_motion(&self) -> bool {
        self.oracle_motion
    }

    fn rng_for(&self, k: u64) -> SmallRng {
        SmallRng::seed_from_u64(self.seed ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17))
    }

    /// The next eye batch with its ground truth (for evaluation and pictures, never for learning).
    pub fn next_eye_batch(&mut self, batch_size: usize) -> &OnsBatch {
        let mut rng = self.rng_for(self.batches);
        self.batches += 1;
        self.retina
            .batch_into(&mut rng, batch_size, &mut self.buffer);
        &self.buffer
    }

    /// The cortex's view of an eye batch: ONS pairs and, if enabled, the oracle motion.
    pub fn training_view(batch: &OnsBatch, oracle_motion: bool) -> TrainingBatch {
        TrainingBatch {
            ons: batch.ons.clone(),
            batch: batch.batch,
            n: batch.n,
            oracle_motion: oracle_motion.then(|| batch.oracle_shift_normalised.clone()),
        }
    }
}

impl DataSource for RetinaSource {
    fn next_batch(&mut self, batch_size: usize) -> TrainingBatch {
        let oracle = self.oracle_motion;
        let b = self.next_eye_batch(batch_size);
        Self::training_view(b, oracle)
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        Some(serde_json::json!({ "batches": self.batches, "seed": self.seed }))
    }

    fn load_state(&mut self, state: &serde_json::Value) -> Result<(), CortexError> {
        let bad = |reason: &str| CortexError::InvalidConfig {
            field: "data_source".into(),
            reason: reason.into(),
        };
        let batches = state
            .get("batches")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| bad("missing `batches`"))?;
        let seed = state
            .get("seed")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| bad("missing `seed`"))?;
        if seed != self.seed {
            return Err(bad(&format!(
                "checkpoint was drawn with seed {seed}, this source has {}",
                self.seed
            )));
        }
        if batches < self.batches {
            return Err(bad("cannot rewind a retina source; build a fresh one"));
        }
        // Each batch has its own RNG, so replaying with one sample per batch rebuilds the
        // pool's refresh state exactly at a fraction of the cost.
        while self.batches < batches {
            self.next_eye_batch(1);
        }
        Ok(())
    }
}
