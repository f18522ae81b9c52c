//! [`RuleState`]: what a learning rule keeps between steps (fixed or learned feedback
//! matrices, running statistics, counters), in a form a checkpoint can hold.
//!
//! A rule's state is a set of named tensors and named strings. Names are the rule's own; the
//! built-in rules key per-parameter tensors by the parameter's *name* in the
//! [`ParamStore`](crate::ParamStore) (`"feedback.d.inc.conv0.weight"`), never by its id, so a
//! state written by one process loads into a model rebuilt by another. A checkpoint stores it
//! as one safetensors file ([`RuleState::save_safetensors`]): the tensors as tensors, the
//! strings as its `__metadata__`, so it opens in PyTorch/NumPy like the parameters.
//!
//! Contract (what makes `resume` bit-identical): after `rule.load_state(&rule.state(p), p)` a
//! rule assigns exactly the credit the saved rule would have assigned on the same tape.

use crate::params::{read_safetensors, write_safetensors, SafetensorsError};
use crate::{Float, Tensor};
use std::collections::BTreeMap;
use std::path::Path;

/// A learning rule's state: named tensors and named strings (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RuleState<T: Float = f32> {
    /// Tensors by name (feedback matrices, statistics).
    pub tensors: BTreeMap<String, Tensor<T>>,
    /// Strings by name (counters, the scheme the tensors belong to).
    pub metadata: BTreeMap<String, String>,
}

impl<T: Float> Default for RuleState<T> {
    fn default() -> Self {
        RuleState {
            tensors: BTreeMap::new(),
            metadata: BTreeMap::new(),
        }
    }
}

/// Why a saved state does not fit a rule.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RuleStateError {
    /// The rule keeps no state of this kind (e.g. a state written by another rule).
    #[error("learning-rule state: `{key}` is not part of this rule's state ({reason})")]
    Unexpected { key: String, reason: String },
    /// A value the rule needs is absent or unreadable.
    #[error("learning-rule state: `{key}`: {reason}")]
    Invalid { key: String, reason: String },
    /// Reading or writing the state file failed.
    #[error(transparent)]
    Io(Box<SafetensorsError>),
}

impl From<SafetensorsError> for RuleStateError {
    fn from(e: SafetensorsError) -> Self {
        RuleStateError::Io(Box::new(e))
    }
}

impl<T: Float> RuleState<T> {
    /// No state.
    pub fn new() -> Self {
        Self::default()
    }

    /// True when the rule keeps nothing.
    pub fn is_empty(&self) -> bool {
        self.tensors.is_empty() && self.metadata.is_empty()
    }

    /// The error for a rule that keeps no state but was handed some: names the first key.
    pub fn unexpected(&self, rule: &str) -> RuleStateError {
        let key = (self.tensors.keys().chain(self.metadata.keys()))
            .next()
            .cloned()
            .unwrap_or_default();
        RuleStateError::Unexpected {
            key,
            reason: format!("{rule} keeps no state"),
        }
    }

    /// The metadata entry `key` parsed as `u64`.
    pub fn counter(&self, key: &str) -> Result<u64, RuleStateError> {
        let text = self
            .metadata
            .get(key)
            .ok_or_else(|| RuleStateError::Invalid {
                key: key.into(),
                reason: "missing".into(),
            })?;
        text.parse().map_err(|e| RuleStateError::Invalid {
            key: key.into(),
            reason: format!("{text:?} is not a count: {e}"),
        })
    }

    /// Writes the state to `path` (safetensors, atomically; an empty state is a valid file).
    pub fn save_safetensors(&self, path: &Path) -> Result<(), RuleStateError> {
        let tensors: Vec<(&str, &Tensor<T>)> =
            self.tensors.iter().map(|(k, t)| (k.as_str(), t)).collect();
        Ok(write_safetensors(path, &tensors, &self.metadata)?)
    }

    /// Reads a state written by [`RuleState::save_safetensors`].
    pub fn load_safetensors(path: &Path) -> Result<Self, RuleStateError> {
        let loaded = read_safetensors::<T>(path)?;
        Ok(RuleState {
            tensors: loaded.tensors,
            metadata: loaded.metadata,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_state_round_trips_through_safetensors_bit_for_bit() {
        let mut s = RuleState::<f32>::new();
        s.tensors.insert(
            "feedback.w".into(),
            Tensor::from_fn([2, 3], |i| (i as f32 * 0.7).sin()),
        );
        s.metadata.insert("draws".into(), "12".into());
        let path = std::env::temp_dir().join(format!("rule-state-{}.st", std::process::id()));
        s.save_safetensors(&path).unwrap();
        let back = RuleState::<f32>::load_safetensors(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(back, s);
        assert_eq!(back.counter("draws").unwrap(), 12);
        assert!(back.counter("steps").is_err());
        let empty = RuleState::<f32>::new();
        empty.save_safetensors(&path).unwrap();
        assert!(RuleState::<f32>::load_safetensors(&path)
            .unwrap()
            .is_empty());
        std::fs::remove_file(&path).unwrap();
        assert!(s.unexpected("backprop").to_string().contains("feedback.w"));
    }
}
