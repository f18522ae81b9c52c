//! Evaluation helpers for the root package: held-out prediction error against "next frame =
//! current frame", and the motion estimator's error against the oracle. Nothing here updates
//! parameters.

use crate::data::OnsBatch;
use crate::trainer::{PredictionError, Trainer};
use crate::CortexError;

impl Trainer {
    /// Prediction error of the cortex on `batch` (no update) and of predicting frame t+1 as
    /// frame t, over the same pixels: inside the `loss.border_px` border and the warp mask.
    pub fn prediction_error(&mut self, batch: &OnsBatch) -> Result<PredictionError, CortexError> {
        self.check_batch(batch)?;
        let (b, n) = (batch.batch, batch.n);
        batch.frames(0, &mut self.frames[0]);
        batch.frames(1, &mut self.frames[1]);
        let motion = self.cortex.estimate_motion(
            &self.frames[0],
            &self.frames[1],
            batch.oracle_motion.as_deref(),
        )?;
        let (pred, _) = self.record_frames((b, n), &motion);
        let (p, m) = (
            self.tape.value(pred.predicted).data(),
            self.tape.value(pred.mask).data(),
        );
        let (f0, f1) = (&self.frames[0], &self.frames[1]);
        let bp = self.cortex.config.loss.border_px;
        let (mut model, mut ident, mut count) = (0.0f64, 0.0f64, 0.0f64);
        for s in 0..b {
            for y in bp..n - bp {
                for x in bp..n - bp {
                    let i = (s * n + y) * n + x;
                    let w = m[i] as f64;
                    model += w * (p[i] as f64 - f1[i] as f64).powi(2);
                    ident += w * (f0[i] as f64 - f1[i] as f64).powi(2);
                    count += w;
                }
            }
        }
        self.tape.clear();
        let count = count.max(1.0);
        Ok(PredictionError {
            model_mse: model / count,
            identity_mse: ident / count,
        })
    }

    /// Distance between the estimated motion and the batch's oracle motion, in ONS pixels of
    /// the identity layout (`(n−1)/2` per field unit). `None` when the batch has no oracle.
    pub fn motion_error_ons_px(
        &mut self,
        batch: &OnsBatch,
    ) -> Result<Option<MotionError>, CortexError> {
        self.check_batch(batch)?;
        let Some(oracle) = batch.oracle_motion.as_ref() else {
            return Ok(None);
        };
        batch.frames(0, &mut self.frames[0]);
        batch.frames(1, &mut self.frames[1]);
        let est = self
            .cortex
            .estimate_motion(&self.frames[0], &self.frames[1], Some(oracle))?;
        let px = (batch.n as f64 - 1.0) / 2.0;
        let mut errs: Vec<f64> = est
            .motion
            .iter()
            .zip(oracle)
            .map(|(e, o)| ((e[0] - o[0] as f64).powi(2) + (e[1] - o[1] as f64).powi(2)).sqrt() * px)
            .collect();
        errs.sort_by(|a, b| a.total_cmp(b));
        let k = errs.len();
        Ok(Some(MotionError {
            mean_px: errs.iter().sum::<f64>() / k as f64,
            median_px: errs[k / 2],
            max_px: errs[k - 1],
            within_1px: errs.iter().filter(|&&e| e <= 1.0).count() as f64 / k as f64,
        }))
    }
}

/// Motion-estimation error against the oracle, in ONS pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionError {
    pub mean_px: f64,
    pub median_px: f64,
    pub max_px: f64,
    /// Fraction of samples within 1 px.
    pub within_1px: f64,
}
