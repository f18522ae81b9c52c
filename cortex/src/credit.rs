//! Between a learning rule and Adam: the rule's update measured against backprop's gradient
//! on the same step (every `train.alignment_every_steps`), then clipped per bucket and as a
//! whole (`[cortex.train]`, see `config::per_bucket`).
//!
//! The measurement (`autodiff::learn::alignment`) runs one more backprop sweep from the
//! step's training loss on the step's tape, after the rule has assigned credit and before
//! anything is clipped, and reports per learned bucket (W, C, D, P) the cosine between the
//! rule's update and backprop's gradient and both norms. Under backprop the cosine is 1 and
//! the norms agree (a check of the measurement itself). It changes nothing the rule returned:
//! training with and without it is the same, bit for bit.

use crate::model::{bucket_of_param, LEARNED_BUCKETS};
use crate::trainer::Trainer;
use autodiff::learn::GroupAlignment;
use autodiff::{ParamStore, Var};

/// The rule's update against backprop's gradient per learned bucket, in the order W, C, D,
/// P; `None` for a bucket without parameters.
pub type Alignment = [Option<GroupAlignment>; 4];

/// The index into [`LEARNED_BUCKETS`] of each parameter, by id.
pub fn learned_bucket_of_params(params: &ParamStore<f32>) -> Vec<Option<usize>> {
    params
        .ids()
        .map(|id| {
            let b = bucket_of_param(params.name(id))?;
            LEARNED_BUCKETS.iter().position(|&x| x == b)
        })
        .collect()
}

impl Trainer {
    /// Whether the step about to be taken measures its alignment with backprop.
    pub(crate) fn alignment_due(&self) -> bool {
        let every = self.cortex.config.train.alignment_every_steps;
        every > 0 && (self.step + 1).is_multiple_of(every)
    }

    /// The rule's update (in `self.grads`) against backprop's gradient of `loss`, per bucket.
    pub(crate) fn measure_alignment(&mut self, loss: Var) -> Alignment {
        let index = learned_bucket_of_params(&self.cortex.params);
        let per_bucket = self
            .meter
            .measure(&mut self.tape, loss, &self.grads, 4, |id| {
                index.get(id.0 as usize).copied().flatten()
            });
        [per_bucket[0], per_bucket[1], per_bucket[2], per_bucket[3]]
    }

    /// Clips the rule's update: each bucket to its `clip_norm`, then the whole to
    /// `clip_global_norm`.
    pub(crate) fn clip_update(&mut self) {
        let train = &self.cortex.config.train;
        let index = learned_bucket_of_params(&self.cortex.params);
        for (k, &bucket) in LEARNED_BUCKETS.iter().enumerate() {
            let Some(max) = train.per_bucket.of(bucket).and_then(|s| s.clip_norm) else {
                continue;
            };
            let ids: Vec<_> = (self.grads.iter())
                .map(|(id, _)| id)
                .filter(|id| index.get(id.0 as usize).copied().flatten() == Some(k))
                .collect();
            let norm = ids
                .iter()
                .map(|&id| self.grads.get(id).map_or(0.0, |g| g.sum_sq()))
                .sum::<f64>()
                .sqrt();
            if norm > max {
                let c = (max / norm) as f32;
                for id in ids {
                    if let Some(g) = self.grads.get_mut(id) {
                        g.data_mut().iter_mut().for_each(|v| *v *= c);
                    }
                }
            }
        }
        if let Some(max) = train.clip_global_norm {
            self.grads.clip_global_norm(max);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::config::CortexConfig;
    use crate::model::{bucket_of_param, Bucket};
    use crate::Trainer;
    use autodiff::Tensor;

    #[test]
    fn clipping_bounds_each_bucket_then_the_whole_update() {
        let mut cfg = CortexConfig::tiny();
        cfg.train.per_bucket.d.clip_norm = Some(0.5);
        cfg.train.clip_global_norm = Some(2.0);
        let mut t = Trainer::new(cfg).unwrap();
        let ids: Vec<_> = t.cortex.params.ids().collect();
        for &id in &ids {
            let shape = t.cortex.params.get(id).shape();
            t.grads.insert(id, Tensor::full(shape, 1.0));
        }
        let norm_of = |t: &Trainer, b: Option<Bucket>| {
            ids.iter()
                .filter(|&&id| b.is_none() || bucket_of_param(t.cortex.params.name(id)) == b)
                .map(|&id| t.grads.get(id).unwrap().sum_sq())
                .sum::<f64>()
                .sqrt()
        };
        let (d0, p0) = (norm_of(&t, Some(Bucket::D)), norm_of(&t, Some(Bucket::P)));
        assert!(d0 > 0.5 && norm_of(&t, None) > 2.0, "the test can fail");
        t.clip_update();
        let total = norm_of(&t, None);
        assert!((total - 2.0).abs() < 1e-4, "global norm {total}");
        // D was clipped to 0.5 first, then everything scaled by the same factor
        let (d, p) = (norm_of(&t, Some(Bucket::D)), norm_of(&t, Some(Bucket::P)));
        let factor = p / p0;
        assert!(
            (d / factor - 0.5).abs() < 1e-4,
            "D before the global clip {}",
            d / factor
        );
        assert!(d0 > d);
    }
}
