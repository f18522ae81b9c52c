//! What the cortex receives: optic-nerve pairs and, only when a run asks for it, the oracle
//! motion. Nothing else from the eye enters (no scene, no cone types, no positions).
//!
//! Layout of [`TrainingBatch::ons`]: `(B, 2, n, n)` row-major f32; axis 1 is time (frame t,
//! frame t+1); axes 2, 3 are ONS rows (y) and columns (x).
//!
//! Motion convention (authors' code, docs/references.md#motion-estimation and #retina-data-flow): `oracle_motion[b] = [dx, dy]`, the eye shift
//! divided by R/2 (R = side of the visual field in px), so that the field spans [−1, 1].
//! x is the column axis, y the row axis (the `grid_sample` order). Sign: frame t+1 at position p
//! shows what frame t showed at p + d.

use crate::CortexError;

/// One training batch: ONS at t and t+1, and optionally the true motion.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingBatch {
    /// `(B, 2, n, n)`: frames t and t+1.
    pub ons: Vec<f32>,
    /// B.
    pub batch: usize,
    /// n, the ONS side.
    pub n: usize,
    /// Per sample `[dx, dy]` in field units (see the module docs); `None` unless the run uses
    /// oracle motion.
    pub oracle_motion: Option<Vec<[f32; 2]>>,
}

impl TrainingBatch {
    /// Checks sizes and finiteness; the error names the field.
    pub fn validate(&self) -> Result<(), CortexError> {
        let want = self.batch * 2 * self.n * self.n;
        if self.batch == 0 || self.n == 0 {
            return Err(CortexError::InvalidBatch {
                field: "batch/n",
                reason: format!("batch {} and n {} must be positive", self.batch, self.n),
            });
        }
        if self.ons.len() != want {
            return Err(CortexError::InvalidBatch {
                field: "ons",
                reason: format!(
                    "{} values, want B·2·n·n = {}·2·{}·{} = {want}",
                    self.ons.len(),
                    self.batch,
                    self.n,
                    self.n
                ),
            });
        }
        if let Some(i) = self.ons.iter().position(|v| !v.is_finite()) {
            return Err(CortexError::InvalidBatch {
                field: "ons",
                reason: format!("value {} at flat index {i} is not finite", self.ons[i]),
            });
        }
        if let Some(m) = &self.oracle_motion {
            if m.len() != self.batch {
                return Err(CortexError::InvalidBatch {
                    field: "oracle_motion",
                    reason: format!("{} entries for a batch of {}", m.len(), self.batch),
                });
            }
            if m.iter().flatten().any(|v| !v.is_finite()) {
                return Err(CortexError::InvalidBatch {
                    field: "oracle_motion",
                    reason: "contains a non-finite value".into(),
                });
            }
        }
        Ok(())
    }

    /// Frame `t` (0 or 1) of sample `b`, `n·n` values.
    pub fn frame(&self, b: usize, t: usize) -> &[f32] {
        let nn = self.n * self.n;
        let start = (b * 2 + t) * nn;
        &self.ons[start..start + nn]
    }

    /// Frame `t` of every sample, gathered into `(B, 1, n, n)`.
    pub fn frames(&self, t: usize, out: &mut Vec<f32>) {
        out.clear();
        for b in 0..self.batch {
            out.extend_from_slice(self.frame(b, t));
        }
    }
}

/// A stream of training batches. The root package implements it with the retina; the cortex
/// crate ships [`crate::synthetic::SyntheticSource`] for tests and benches.
///
/// For exact resume, a source may expose its state (its RNG, its position in a dataset):
/// [`crate::Trainer`] stores it in checkpoints and restores it on resume.
pub trait DataSource {
    /// The next batch of `batch_size` pairs.
    fn next_batch(&mut self, batch_size: usize) -> TrainingBatch;

    /// The source's resumable state, if it has one.
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }

    /// Restores a state returned by [`DataSource::save_state`].
    fn load_state(&mut self, _state: &serde_json::Value) -> Result<(), CortexError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_bad_field() {
        let mut b = TrainingBatch {
            ons: vec![0.0; 2 * 2 * 4 * 4],
            batch: 2,
            n: 4,
            oracle_motion: Some(vec![[0.0, 0.0]; 2]),
        };
        b.validate().unwrap();
        b.ons.pop();
        assert!(b.validate().unwrap_err().to_string().contains("`ons`"));
        b.ons.push(f32::NAN);
        assert!(b.validate().unwrap_err().to_string().contains("not finite"));
        b.ons[63] = 0.0;
        b.oracle_motion = Some(vec![[0.0, 0.0]]);
        assert!(b
            .validate()
            .unwrap_err()
            .to_string()
            .contains("oracle_motion"));
    }

    #[test]
    fn frames_are_gathered_in_batch_order() {
        let b = TrainingBatch {
            ons: (0..2 * 2 * 9).map(|i| i as f32).collect(),
            batch: 2,
            n: 3,
            oracle_motion: None,
        };
        let mut out = Vec::new();
        b.frames(1, &mut out);
        assert_eq!(out[0], 9.0);
        assert_eq!(out[9], 27.0);
    }
}
