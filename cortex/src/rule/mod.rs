//! The learning rules a run can name (`learning_rule` in a run's TOML), and how each is built
//! for a cortex. Names are kebab-case; an unknown name is rejected while the settings are
//! read, listing these.
//!
//! | name | rule | state |
//! |---|---|---|
//! | `backprop` | `autodiff::learn::Backprop` | none |
//! | `feedback-alignment` | `autodiff::learn::FeedbackAlignment` (Lillicrap et al. 2016) | backward weights from the seed, scaled to the start parameters |
//! | `direct-feedback-alignment` | `autodiff::learn::DirectFeedbackAlignment` (Nøkland 2016) | feedback matrices from the seed alone |
//! | `forward-forward` | `autodiff::learn::ForwardForward` (Hinton 2022) with the cortex's local objectives ([`crate::forward_forward`]) | none |
//!
//! Every rule's state is a function of the seed and the parameters the run started from, so a
//! resumed run rebuilds exactly the rule of the run that never stopped.

use autodiff::learn::{
    Backprop, DirectFeedbackAlignment, FeedbackAlignment, ForwardForward, LearningRule,
};
use autodiff::ParamStore;
use serde::{Deserialize, Serialize};

/// A learning rule by name (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RuleKind {
    /// Exact gradients.
    #[default]
    Backprop,
    /// Fixed random backward weights for every conv and matmul kernel.
    FeedbackAlignment,
    /// The prediction error projected by fixed random matrices to every tagged layer.
    DirectFeedbackAlignment,
    /// Layer-local goodness objectives on real against wrong-motion data.
    ForwardForward,
}

impl RuleKind {
    /// Every rule, in the order of the module docs.
    pub const ALL: [RuleKind; 4] = [
        RuleKind::Backprop,
        RuleKind::FeedbackAlignment,
        RuleKind::DirectFeedbackAlignment,
        RuleKind::ForwardForward,
    ];

    /// The name in a TOML file.
    pub fn name(self) -> &'static str {
        match self {
            RuleKind::Backprop => "backprop",
            RuleKind::FeedbackAlignment => "feedback-alignment",
            RuleKind::DirectFeedbackAlignment => "direct-feedback-alignment",
            RuleKind::ForwardForward => "forward-forward",
        }
    }

    /// One line for a run's log.
    pub fn describe(self) -> &'static str {
        match self {
            RuleKind::Backprop => "backprop (exact gradients)",
            RuleKind::FeedbackAlignment => {
                "feedback alignment (fixed random backward weights for conv/matmul kernels)"
            }
            RuleKind::DirectFeedbackAlignment => {
                "direct feedback alignment (prediction error projected by fixed random matrices to W, C, D and every U-Net block of decode)"
            }
            RuleKind::ForwardForward => {
                "forward-forward (per-bucket goodness, real against wrong eye motion; no gradient between buckets)"
            }
        }
    }

    /// The rule, its random state drawn from `seed`; `start` are the parameters the run
    /// started from (feedback alignment scales its backward weights to them).
    pub fn build(self, seed: u64, start: &ParamStore<f32>) -> Box<dyn LearningRule<f32>> {
        match self {
            RuleKind::Backprop => Box::new(Backprop),
            RuleKind::FeedbackAlignment => Box::new(FeedbackAlignment::scaled_to(seed, start)),
            RuleKind::DirectFeedbackAlignment => Box::new(DirectFeedbackAlignment::new(seed)),
            RuleKind::ForwardForward => Box::new(ForwardForward),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    struct Settings {
        #[allow(dead_code)]
        learning_rule: RuleKind,
    }

    #[test]
    fn names_read_back_and_an_unknown_one_lists_them_all() {
        for k in RuleKind::ALL {
            let v: serde_json::Value = serde_json::to_value(k).unwrap();
            assert_eq!(v, k.name());
        }
        let e = serde_json::from_str::<Settings>(r#"{"learning_rule": "hebb"}"#)
            .err()
            .unwrap()
            .to_string();
        for k in RuleKind::ALL {
            assert!(e.contains(k.name()), "{e}");
        }
    }
}
