//! The optic nerve signal in batches: what the eye sends and the cortex receives — optic-nerve
//! pairs and, only when a run asks for it, the oracle eye motion. Nothing else from the eye
//! enters (no scene, no cone types, no positions): the eye keeps its ground truth beside the
//! batch (`retina::BatchTruth`), and the cortex crate depends on this crate, never on the retina.
//!
//! Layout of [`OnsBatch::ons`]: `(B, 2, n, n)` row-major f32; axis 1 is time (frame t,
//! frame t+1); axes 2, 3 are ONS rows (y) and columns (x).
//!
//! Motion convention (authors' code, docs/references.md#motion-estimation and
//! #retina-data-flow): `oracle_motion[b] = [dx, dy]`, the eye shift divided by R/2 (R = side of
//! the visual field in px), so that the field spans [−1, 1]. x is the column axis, y the row
//! axis (the `grid_sample` order). Sign: frame t+1 at position p shows what frame t showed at
//! p + d.

use std::fmt;

/// One batch of the optic nerve signal: ONS at t and t+1, and optionally the true motion.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OnsBatch {
    /// `(B, 2, n, n)`: frames t and t+1.
    pub ons: Vec<f32>,
    /// B.
    pub batch: usize,
    /// n, the ONS side.
    pub n: usize,
    /// Per sample `[dx, dy]` in field units (module docs); `None` unless the run uses oracle
    /// motion.
    pub oracle_motion: Option<Vec<[f32; 2]>>,
}

/// A batch whose sizes disagree or whose values are not finite; names the field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BatchError {
    /// `ons`, `batch/n` or `oracle_motion`.
    pub field: &'static str,
    /// What is wrong, with the numbers.
    pub reason: String,
}

impl fmt::Display for BatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "field `{}`: {}", self.field, self.reason)
    }
}

impl std::error::Error for BatchError {}

impl OnsBatch {
    /// Checks sizes and finiteness; the error names the field.
    pub fn validate(&self) -> Result<(), BatchError> {
        let bad = |field, reason| Err(BatchError { field, reason });
        let want = self.batch * 2 * self.n * self.n;
        if self.batch == 0 || self.n == 0 {
            let reason = format!("batch {} and n {} must be positive", self.batch, self.n);
            return bad("batch/n", reason);
        }
        if self.ons.len() != want {
            let reason = format!(
                "{} values, want B·2·n·n = {}·2·{}·{} = {want}",
                self.ons.len(),
                self.batch,
                self.n,
                self.n
            );
            return bad("ons", reason);
        }
        if let Some(i) = self.ons.iter().position(|v| !v.is_finite()) {
            let reason = format!("value {} at flat index {i} is not finite", self.ons[i]);
            return bad("ons", reason);
        }
        if let Some(m) = &self.oracle_motion {
            if m.len() != self.batch {
                let reason = format!("{} entries for a batch of {}", m.len(), self.batch);
                return bad("oracle_motion", reason);
            }
            if m.iter().flatten().any(|v| !v.is_finite()) {
                return bad("oracle_motion", "contains a non-finite value".into());
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_bad_field() {
        let mut b = OnsBatch {
            ons: vec![0.0; 2 * 2 * 4 * 4],
            batch: 2,
            n: 4,
            oracle_motion: Some(vec![[0.0, 0.0]; 2]),
        };
        b.validate().unwrap();
        b.ons.pop();
        assert_eq!(b.validate().unwrap_err().field, "ons");
        b.ons.push(f32::NAN);
        assert!(b.validate().unwrap_err().to_string().contains("not finite"));
        b.ons[63] = 0.0;
        b.oracle_motion = Some(vec![[0.0, 0.0]]);
        assert_eq!(b.validate().unwrap_err().field, "oracle_motion");
        b.oracle_motion = None;
        b.batch = 0;
        assert_eq!(b.validate().unwrap_err().field, "batch/n");
    }

    #[test]
    fn frames_are_gathered_in_batch_order() {
        let b = OnsBatch {
            ons: (0..2 * 2 * 9).map(|i| i as f32).collect(),
            batch: 2,
            n: 3,
            oracle_motion: None,
        };
        assert_eq!(b.frame(1, 0)[0], 18.0);
        let mut out = Vec::new();
        b.frames(1, &mut out);
        assert_eq!(out.len(), 18);
        assert_eq!(out[0], 9.0);
        assert_eq!(out[9], 27.0);
    }
}
