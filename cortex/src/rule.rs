//! The learning rules a run can name, as an open registry: `learning_rule = "NAME"` in a
//! run's TOML selects a rule, the `[rule]` table holds its settings, and a rule written
//! outside the library joins by one call to [`register`] in the user's own binary, before the
//! configuration is read.
//!
//! Built in ([`builtin`] holds each rule's settings and defaults):
//!
//! | name | rule | settings (`[rule]`) | state in checkpoints |
//! |---|---|---|---|
//! | `backprop` | `autodiff::learn::Backprop` | — | none |
//! | `feedback-alignment` | `autodiff::learn::FeedbackAlignment` (Lillicrap et al. 2016; sign-concordant: Liao et al. 2016) | `scheme` (`random`, `usf`, `brsf`, `frsf`), `norm_matched`, `flip_sign`, `buckets` (of W, D, P; default D, P), `feedback_seed` | magnitudes of `B`, steps |
//! | `kolen-pollack` | the same with `B` learned (Kolen & Pollack 1994; Akrout et al. 2019) by its own Adam (or SGD) on `W`'s gradient | `learning_rate`, `optimizer` (`adam`, `sgd`), `weight_decay`, `buckets`, `feedback_seed` | `B`, its Adam moments, steps |
//! | `direct-feedback-alignment` | `autodiff::learn::DirectFeedbackAlignment` (Nøkland 2016), a random `k × k` convolution of the prediction error per layer | `kernel_px`, `buckets` (of W, C, D; default all three), `feedback_seed` | the projections |
//! | `forward-forward` | `autodiff::learn::ForwardForward` (Hinton 2022) with the cortex's layer-local objectives ([`crate::forward_forward`]) | `objective` (`goodness`, or `prediction`: each layer's own prediction of the next ONS) | none |
//!
//! Where feedback alignment can act, said plainly: it replaces weights in backward, and only
//! an op's *weight input* that is a parameter can be replaced. In this cortex those are the
//! convolutions of D, the coupling MLPs of P and W's frequency response in its encode (the
//! complex multiply); C is normalised before every use, so its parameter never reaches an op
//! as a weight, and `buckets` may not name it. Direct feedback alignment acts on the tagged
//! layers of decode (W's and C's outputs and every layer of D); P sits in the output mapping
//! and takes the true error, so `buckets` may not name it.
//!
//! Every rule's random state is drawn from `feedback_seed` (default: the run's seed), so a
//! seed sweep and a sweep of feedback draws are separate axes. The rule's state is saved in
//! each checkpoint (`rule.safetensors`) and restored on resume ([`crate::Trainer`]).
//!
//! Names are kebab-case; an unknown name or a setting a rule does not have is an error
//! naming it and listing what is known.

pub mod builtin;

use crate::CortexError;
use autodiff::learn::LearningRule;
use autodiff::ParamStore;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, LazyLock, RwLock};

/// A rule's settings as written in the `[rule]` table of a run's config.
pub type RuleSettings = serde_json::Map<String, serde_json::Value>;

/// The name of a registered rule (`learning_rule` in a run's TOML).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct RuleName(pub String);

impl Default for RuleName {
    fn default() -> Self {
        RuleName("backprop".into())
    }
}

impl RuleName {
    /// The name as written.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// Whether this is plain backprop (nothing to announce, nothing to build).
    pub fn is_backprop(&self) -> bool {
        self.0 == "backprop"
    }
}

impl std::fmt::Display for RuleName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// What a rule is built from.
pub struct RuleContext<'a> {
    /// The run's seed.
    pub seed: u64,
    /// The parameters the training started from (feedback alignment scales its draws to
    /// them, so a resumed run draws what the run that never stopped drew).
    pub start: &'a ParamStore<f32>,
}

impl RuleContext<'_> {
    /// The seed of a rule's random draws: `feedback_seed` when given, else the run's, mixed
    /// so a draw never equals the initialisation's stream.
    pub fn draw_seed(&self, feedback_seed: Option<u64>) -> u64 {
        feedback_seed.unwrap_or(self.seed) ^ 0xFA
    }
}

/// Parses settings and, given a context, builds the rule (`None` without one: a check).
type Build = dyn Fn(
        &RuleSettings,
        Option<&RuleContext<'_>>,
    ) -> Result<Option<Box<dyn LearningRule<f32>>>, String>
    + Send
    + Sync;

/// One registered rule: its name, a line describing it, and how to build it.
pub struct RuleEntry {
    name: String,
    summary: String,
    build: Box<Build>,
}

impl RuleEntry {
    /// A rule named `name` (kebab-case), described by `summary`, whose settings `S` are read
    /// from the `[rule]` table with serde (give `S` `#[serde(deny_unknown_fields)]` so a typo
    /// is an error; [`builtin::NoSettings`] for none) and built by `build`.
    pub fn new<S, F>(name: &str, summary: &str, build: F) -> Self
    where
        S: DeserializeOwned,
        F: Fn(S, &RuleContext<'_>) -> Box<dyn LearningRule<f32>> + Send + Sync + 'static,
    {
        let build = move |settings: &RuleSettings, ctx: Option<&RuleContext<'_>>| {
            let value = serde_json::Value::Object(settings.clone());
            let s: S = serde_json::from_value(value).map_err(|e| e.to_string())?;
            Ok(ctx.map(|ctx| build(s, ctx)))
        };
        RuleEntry {
            name: name.to_string(),
            summary: summary.to_string(),
            build: Box::new(build),
        }
    }

    /// The name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The line describing it.
    pub fn summary(&self) -> &str {
        &self.summary
    }
}

static REGISTRY: LazyLock<RwLock<Vec<Arc<RuleEntry>>>> =
    LazyLock::new(|| RwLock::new(builtin::entries().into_iter().map(Arc::new).collect()));

fn entries() -> Vec<Arc<RuleEntry>> {
    REGISTRY.read().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Adds a rule to the registry for the rest of the process. An error when the name is empty,
/// not kebab-case, or taken.
pub fn register(entry: RuleEntry) -> Result<(), CortexError> {
    let name = entry.name.clone();
    let kebab = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-');
    if !kebab {
        return Err(invalid(
            "learning_rule",
            format!("{name:?}: a rule's name is kebab-case (a-z, 0-9, -)"),
        ));
    }
    let mut registry = REGISTRY.write().unwrap_or_else(|e| e.into_inner());
    if registry.iter().any(|e| e.name == name) {
        return Err(invalid(
            "learning_rule",
            format!("{name:?} is registered already"),
        ));
    }
    registry.push(Arc::new(entry));
    Ok(())
}

/// `(name, summary)` of every registered rule, built-in ones first.
pub fn registered() -> Vec<(String, String)> {
    entries()
        .iter()
        .map(|e| (e.name.clone(), e.summary.clone()))
        .collect()
}

fn invalid(field: &str, reason: String) -> CortexError {
    CortexError::InvalidConfig {
        field: field.to_string(),
        reason,
    }
}

fn entry(name: &RuleName) -> Result<Arc<RuleEntry>, CortexError> {
    let all = entries();
    all.iter()
        .find(|e| e.name == name.0)
        .cloned()
        .ok_or_else(|| {
            let names: Vec<&str> = all.iter().map(|e| e.name.as_str()).collect();
            invalid(
                "learning_rule",
                format!(
                    "unknown rule {:?}; registered: {}",
                    name.0,
                    names.join(", ")
                ),
            )
        })
}

/// Checks that `name` is registered and that `settings` are its settings.
pub fn check(name: &RuleName, settings: &RuleSettings) -> Result<(), CortexError> {
    (entry(name)?.build)(settings, None)
        .map(|_| ())
        .map_err(|e| invalid("rule", format!("settings of {name}: {e}")))
}

/// Builds the rule `name` with `settings`.
pub fn build(
    name: &RuleName,
    settings: &RuleSettings,
    ctx: &RuleContext<'_>,
) -> Result<Box<dyn LearningRule<f32>>, CortexError> {
    let built = (entry(name)?.build)(settings, Some(ctx))
        .map_err(|e| invalid("rule", format!("settings of {name}: {e}")))?;
    Ok(built.expect("a context builds the rule"))
}

/// The built-in rules' names, in the order of the module table.
pub const BUILT_IN: [&str; 5] = [
    "backprop",
    "feedback-alignment",
    "kolen-pollack",
    "direct-feedback-alignment",
    "forward-forward",
];

/// The rule `name` with its default settings, its random state drawn from `seed` and fitted
/// to `start` (benches, tests, a trainer driven from code).
pub fn with_defaults(
    name: &str,
    seed: u64,
    start: &ParamStore<f32>,
) -> Result<Box<dyn LearningRule<f32>>, CortexError> {
    let ctx = RuleContext { seed, start };
    build(&RuleName(name.into()), &RuleSettings::new(), &ctx)
}

/// One line for a run's log: the rule's summary and its settings.
pub fn describe(name: &RuleName, settings: &RuleSettings) -> String {
    let summary = entry(name).map_or_else(|_| String::new(), |e| e.summary.clone());
    if settings.is_empty() {
        format!("{name}: {summary}")
    } else {
        let s = serde_json::Value::Object(settings.clone());
        format!("{name} ({s}): {summary}")
    }
}

#[cfg(test)]
mod tests;
