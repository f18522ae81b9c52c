//! The retina as the cortex's data source: the only door between the eye and the brain.
//!
//! [`RetinaSource`] has the eye write each batch's signal straight into the cortex's
//! [`OnsBatch`] (the one batch type from eye to tape) and keeps the ground truth
//! ([`retina::BatchTruth`]) behind; only when the run asks for it (`oracle_motion = true`) does
//! it copy the true eye shift into the batch. Scene pixels, cone types, positions and the
//! lateral-inhibition kernel stay behind.
//!
//! Determinism: batch k is drawn with an RNG seeded from `(seed, k)`, so the source's whole state
//! is the number of batches drawn; resuming passes over that many batches
//! ([`RetinaSource::skip_batches`]) to rebuild the scene pool's refresh state exactly.

use cortex::{CortexError, DataSource, OnsBatch};
use rand::rngs::SmallRng;
use rand::SeedableRng;
use retina::{BatchTruth, EyeBatch, Retina};

/// Feeds a cortex from a simulated eye.
pub struct RetinaSource {
    /// The eye (ground truth stays here; the cortex never receives it).
    pub retina: Retina,
    seed: u64,
    batches: u64,
    oracle_motion: bool,
    /// The truth of the last batch handed to the cortex (kept here, never sent).
    truth: BatchTruth,
    /// The last batch drawn by [`RetinaSource::next_eye_batch`].
    eye: EyeBatch,
}

impl RetinaSource {
    /// A source drawing batches from `retina` with `seed`; `oracle_motion` passes the true shift.
    pub fn new(retina: Retina, seed: u64, oracle_motion: bool) -> Self {
        RetinaSource {
            retina,
            seed,
            batches: 0,
            oracle_motion,
            truth: BatchTruth::default(),
            eye: EyeBatch::default(),
        }
    }

    /// Number of batches drawn or passed over so far.
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

    /// Draws the next batch: its signal into `signal`, its truth into `truth`; the oracle
    /// motion goes into the signal only when the run asks for it.
    fn draw(&mut self, batch_size: usize, signal: &mut OnsBatch, truth: &mut BatchTruth) {
        let mut rng = self.rng_for(self.batches);
        self.batches += 1;
        self.retina.batch_into(&mut rng, batch_size, signal, truth);
        if self.oracle_motion {
            let motion = signal.oracle_motion.get_or_insert_with(Vec::new);
            motion.clear();
            motion.extend_from_slice(&truth.oracle_shift_normalised);
        }
    }

    /// Passes over batches ([`Self::skip_batches`]) until `batches` have been drawn or passed
    /// over: each batch has its own RNG, so this rebuilds the scene pool's refresh state exactly
    /// at the cost of its tile refreshes alone (resuming, and sampling the scenes of a whole
    /// training).
    pub fn replay_to(&mut self, batches: u64) {
        self.skip_batches(batches.saturating_sub(self.batches));
    }

    /// Passes over the next `batches` batches without drawing them: the scene pool changes as
    /// if they had been drawn ([`Retina::skip_batch`]), so the batch after them is the one a
    /// source that drew them would draw next, bit for bit. The last batch's signal and truth
    /// stay those of the last batch drawn.
    pub fn skip_batches(&mut self, batches: u64) {
        for _ in 0..batches {
            let mut rng = self.rng_for(self.batches);
            self.batches += 1;
            self.retina.skip_batch(&mut rng);
        }
    }

    /// The next eye batch with its ground truth (for evaluation and pictures, never for
    /// learning). It counts as a drawn batch, like [`DataSource::next_batch_into`].
    pub fn next_eye_batch(&mut self, batch_size: usize) -> &EyeBatch {
        let mut eye = std::mem::take(&mut self.eye);
        self.draw(batch_size, &mut eye.signal, &mut eye.truth);
        self.eye = eye;
        &self.eye
    }

    /// [`Self::next_eye_batch`] beside the eye it was drawn from, for a caller that reads the
    /// batch's truth through the eye while holding the batch.
    pub fn next_eye_batch_with_retina(&mut self, batch_size: usize) -> (&Retina, &EyeBatch) {
        self.next_eye_batch(batch_size);
        (&self.retina, &self.eye)
    }
}

impl DataSource for RetinaSource {
    fn next_batch_into(&mut self, batch_size: usize, out: &mut OnsBatch) {
        let mut truth = std::mem::take(&mut self.truth);
        self.draw(batch_size, out, &mut truth);
        self.truth = truth;
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
        self.replay_to(batches);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RunConfig;

    /// A stream of a `tiny` LMS eye whose pool of 4 tiles replaces one every `refresh` batches.
    fn stream(refresh: usize) -> RetinaSource {
        let mut config = RunConfig::preset("tiny", "LMS").unwrap();
        config.retina.scenes.tiles = 4;
        config.retina.scenes.refresh_every_batches = refresh;
        crate::heldout::heldout_source(&config, true).unwrap()
    }

    #[test]
    fn a_skipped_batch_leaves_the_stream_where_drawing_it_would() {
        // A new tile every batch, and every third batch (5 skipped: a refresh boundary crossed).
        for refresh in [1, 3] {
            let (mut drawn, mut skipped) = (stream(refresh), stream(refresh));
            for _ in 0..5 {
                drawn.next_eye_batch(3);
            }
            skipped.skip_batches(5);
            assert_eq!(skipped.batches_drawn(), 5);
            for _ in 0..2 {
                let a = drawn.next_eye_batch(3).clone();
                let b = skipped.next_eye_batch(3);
                assert_eq!(a.truth.tiles, b.truth.tiles, "refresh every {refresh}");
                assert!(
                    a == *b,
                    "refresh every {refresh}: the batch after the skip differs"
                );
            }
        }
    }

    #[test]
    fn a_stream_that_skips_nothing_draws_its_first_batch() {
        let (mut a, mut b) = (stream(1), stream(1));
        b.skip_batches(0);
        b.replay_to(0);
        assert!(*a.next_eye_batch(2) == *b.next_eye_batch(2));
    }
}
