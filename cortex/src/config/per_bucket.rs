//! Per-bucket training settings (`[cortex.train.per_bucket.w]`, `.c`, `.d`, `.p`): a factor on
//! the learning rate of each bucket's parameters and a bound on the norm of each bucket's
//! update, with the run-wide bound `clip_global_norm` beside them in `[cortex.train]`.
//!
//! - `learning_rate_scale` multiplies `learning_rate` (and its schedule) for the bucket's
//!   parameters; 0 holds the bucket where it starts (Adam's step is then exactly zero), a
//!   control such as "D frozen". The older key `w_learning_rate_scale` keeps working: it is
//!   W's factor when `per_bucket.w.learning_rate_scale` is left at 1 (giving both, each
//!   different from 1, is an error naming them).
//! - Clipping acts on what the learning rule returns, before the optimiser: first each
//!   bucket whose update has a Frobenius norm above its `clip_norm` is scaled down to it,
//!   then the whole update to `clip_global_norm` (`autodiff::learn::ParamGrads`). Absent:
//!   no clipping (the authors' code clips nothing). The alignment with backprop
//!   ([`super::TrainConfig::alignment_every_steps`]) is measured on the rule's update before
//!   clipping.

use super::TrainConfig;
use crate::model::Bucket;
use serde::{Deserialize, Serialize};

/// One bucket's training settings (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BucketTrain {
    /// Factor on the learning rate of the bucket's parameters (1: the run's rate).
    #[serde(default = "unit")]
    pub learning_rate_scale: f64,
    /// Largest Frobenius norm of the bucket's update (absent: not clipped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_norm: Option<f64>,
}

fn unit() -> f64 {
    1.0
}

impl Default for BucketTrain {
    fn default() -> Self {
        BucketTrain {
            learning_rate_scale: 1.0,
            clip_norm: None,
        }
    }
}

/// The settings of the buckets that hold parameters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerBucketTrain {
    /// W, the lateral-inhibition filter.
    #[serde(default)]
    pub w: BucketTrain,
    /// C, the cone types.
    #[serde(default)]
    pub c: BucketTrain,
    /// D, the demosaicker.
    #[serde(default)]
    pub d: BucketTrain,
    /// P, the cell positions.
    #[serde(default)]
    pub p: BucketTrain,
}

impl PerBucketTrain {
    /// The settings of bucket `b` (`None` for M and the loss, which hold no parameters).
    pub fn of(&self, b: Bucket) -> Option<&BucketTrain> {
        match b {
            Bucket::W => Some(&self.w),
            Bucket::C => Some(&self.c),
            Bucket::D => Some(&self.d),
            Bucket::P => Some(&self.p),
            Bucket::M | Bucket::Loss => None,
        }
    }
}

impl TrainConfig {
    /// The factor on the learning rate of bucket `b`'s parameters (module docs).
    pub fn learning_rate_scale(&self, b: Bucket) -> f64 {
        let scale = self.per_bucket.of(b).map_or(1.0, |s| s.learning_rate_scale);
        if b == Bucket::W {
            scale * self.w_learning_rate_scale
        } else {
            scale
        }
    }

    /// Checks the per-bucket settings and the global clip; the error names the field.
    pub(super) fn validate_per_bucket(&self) -> Result<(), (String, String)> {
        let p = &self.per_bucket;
        for (name, s) in [("w", &p.w), ("c", &p.c), ("d", &p.d), ("p", &p.p)] {
            let field = |f: &str| format!("train.per_bucket.{name}.{f}");
            let lr = s.learning_rate_scale;
            if !(lr.is_finite() && lr >= 0.0) {
                return Err((
                    field("learning_rate_scale"),
                    format!("{lr} must be finite and ≥ 0 (0 holds the bucket fixed)"),
                ));
            }
            if let Some(c) = s.clip_norm.filter(|c| !(c.is_finite() && *c > 0.0)) {
                return Err((field("clip_norm"), format!("{c} must be finite and > 0")));
            }
        }
        if p.w.learning_rate_scale != 1.0 && self.w_learning_rate_scale != 1.0 {
            return Err((
                "train.w_learning_rate_scale".into(),
                format!(
                    "{} and train.per_bucket.w.learning_rate_scale = {} both set W's factor: \
                     give one",
                    self.w_learning_rate_scale, p.w.learning_rate_scale
                ),
            ));
        }
        if let Some(c) = self
            .clip_global_norm
            .filter(|c| !(c.is_finite() && *c > 0.0))
        {
            return Err((
                "train.clip_global_norm".into(),
                format!("{c} must be finite and > 0"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::config::CortexConfig;
    use crate::model::Bucket;

    #[test]
    fn the_old_w_key_and_the_per_bucket_table_set_the_same_factor() {
        let text = toml::to_string(&CortexConfig::tiny()).unwrap();
        let old = text.replace("w_learning_rate_scale = 1.0", "w_learning_rate_scale = 3.0");
        let c: CortexConfig = toml::from_str(&old).unwrap();
        assert_eq!(c.train.learning_rate_scale(Bucket::W), 3.0);
        let mut new = CortexConfig::tiny();
        new.train.per_bucket.w.learning_rate_scale = 3.0;
        new.train.per_bucket.d.learning_rate_scale = 0.0;
        let back: CortexConfig = toml::from_str(&toml::to_string(&new).unwrap()).unwrap();
        assert_eq!(back, new);
        assert_eq!(back.train.learning_rate_scale(Bucket::W), 3.0);
        assert_eq!(back.train.learning_rate_scale(Bucket::D), 0.0);
        assert_eq!(back.train.learning_rate_scale(Bucket::P), 1.0);
        let mut both = new.clone();
        both.train.w_learning_rate_scale = 2.0;
        let e = both.validate().unwrap_err().to_string();
        assert!(
            e.contains("w_learning_rate_scale") && e.contains("give one"),
            "{e}"
        );
        let mut bad = CortexConfig::tiny();
        bad.train.per_bucket.p.clip_norm = Some(-1.0);
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("train.per_bucket.p.clip_norm"), "{e}");
        bad.train.per_bucket.p.clip_norm = None;
        bad.train.clip_global_norm = Some(f64::NAN);
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("clip_global_norm"));
    }
}
