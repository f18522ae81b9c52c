//! The built-in rules of the registry ([`super`]) and their settings, each field with its
//! default. A setting not listed here is an error naming it.

use super::{RuleContext, RuleEntry};
use crate::model::{bucket_of_scope, Bucket, BUCKET_NAMES};
use autodiff::learn::feedback::KolenPollackOptimizer;
use autodiff::learn::{
    Backprop, DirectFeedbackAlignment, FeedbackAlignment, FeedbackScheme, ForwardForward,
    LearningRule, LocalObjective,
};
use autodiff::scopes::ScopeFilter;
use serde::Deserialize;

/// Settings of a rule that has none: any key is an error.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoSettings {}

/// The sign-concordant and random schemes a config names.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SchemeName {
    /// Fixed random Gaussian `B`.
    #[default]
    Random,
    /// `σ·sign(W)`.
    Usf,
    /// `|R_t| ⊙ sign(W)`, redrawn every step.
    Brsf,
    /// `|R| ⊙ sign(W)`, fixed.
    Frsf,
}

/// `feedback-alignment`'s settings.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedbackSettings {
    /// How `B` is made (default `random`).
    #[serde(default)]
    pub scheme: SchemeName,
    /// Rescale `B` to `‖W‖` at every step (default false).
    #[serde(default)]
    pub norm_matched: bool,
    /// Send `−B`: a control (default false).
    #[serde(default)]
    pub flip_sign: bool,
    /// Buckets it acts in, of W, D, P (default D and P; backprop elsewhere).
    #[serde(default = "weight_buckets")]
    pub buckets: WeightBuckets,
    /// Seed of the draws (default: the run's seed).
    #[serde(default)]
    pub feedback_seed: Option<u64>,
}

/// How `kolen-pollack` trains `B`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KpOptimizer {
    /// Adam with moments of its own, as the cortex trains `W`.
    #[default]
    Adam,
    /// Plain SGD (exact Kolen–Pollack under SGD).
    Sgd,
}

/// `kolen-pollack`'s settings.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KolenPollackSettings {
    /// `η` of `B`'s update (default 1e-3, the cortex's Adam rate).
    #[serde(default = "kp_learning_rate")]
    pub learning_rate: f64,
    /// How `B` is trained: `adam` (default) or `sgd`.
    #[serde(default)]
    pub optimizer: KpOptimizer,
    /// `λ` on `W` and `B` (default 1e-4).
    #[serde(default = "kp_weight_decay")]
    pub weight_decay: f64,
    /// Buckets it acts in, of W, D, P (default D and P).
    #[serde(default = "weight_buckets")]
    pub buckets: WeightBuckets,
    /// Seed of `B`'s starting draw (default: the run's seed).
    #[serde(default)]
    pub feedback_seed: Option<u64>,
}

/// `direct-feedback-alignment`'s settings.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectFeedbackSettings {
    /// Side `k` of each layer's feedback kernel, odd (default 3).
    #[serde(default = "kernel_px")]
    pub kernel_px: KernelPx,
    /// Buckets whose tagged layers get direct feedback, of W, C, D (default all three).
    #[serde(default = "tagged_buckets")]
    pub buckets: TaggedBuckets,
    /// Seed of the projections (default: the run's seed).
    #[serde(default)]
    pub feedback_seed: Option<u64>,
}

/// The local objectives `forward-forward` asks of the cortex ([`crate::forward_forward`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ObjectiveName {
    /// Right against wrong eye motion per layer (Hinton's goodness, the default).
    #[default]
    Goodness,
    /// Each layer predicts the next ONS through a fixed random read-out of its own.
    Prediction,
}

/// `forward-forward`'s settings.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForwardForwardSettings {
    /// The local objectives: `goodness` (default) or `prediction`.
    #[serde(default)]
    pub objective: ObjectiveName,
}

fn kp_learning_rate() -> f64 {
    1e-3
}

fn kp_weight_decay() -> f64 {
    1e-4
}

fn kernel_px() -> KernelPx {
    KernelPx(autodiff::learn::direct_feedback::DEFAULT_KERNEL_PX)
}

/// An odd feedback kernel side, 1..=15.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(try_from = "usize")]
pub struct KernelPx(pub usize);

impl TryFrom<usize> for KernelPx {
    type Error = String;
    fn try_from(k: usize) -> Result<Self, String> {
        if k % 2 == 1 && k <= 15 {
            Ok(KernelPx(k))
        } else {
            Err(format!("kernel_px {k} must be odd and at most 15"))
        }
    }
}

/// Buckets named in a config, checked against those a rule can act in.
fn buckets(names: Vec<String>, allowed: &[Bucket], why: &str) -> Result<Vec<Bucket>, String> {
    names
        .iter()
        .map(|n| {
            let b = bucket_of_scope(&n.to_uppercase()).filter(|b| allowed.contains(b));
            b.ok_or_else(|| {
                let ok: Vec<&str> = allowed.iter().map(|&b| BUCKET_NAMES[b as usize]).collect();
                format!(
                    "bucket {n:?}: this rule acts in {} only ({why})",
                    ok.join(", ")
                )
            })
        })
        .collect()
}

/// Buckets with weight inputs: W, D, P.
#[derive(Clone, Debug, Deserialize)]
#[serde(try_from = "Vec<String>")]
pub struct WeightBuckets(pub Vec<Bucket>);

impl TryFrom<Vec<String>> for WeightBuckets {
    type Error = String;
    fn try_from(names: Vec<String>) -> Result<Self, String> {
        let why = "C is normalised before use, so no op sees its parameter as a weight";
        buckets(names, &[Bucket::W, Bucket::D, Bucket::P], why).map(WeightBuckets)
    }
}

fn weight_buckets() -> WeightBuckets {
    WeightBuckets(vec![Bucket::D, Bucket::P])
}

/// Buckets with tagged layers: W, C, D.
#[derive(Clone, Debug, Deserialize)]
#[serde(try_from = "Vec<String>")]
pub struct TaggedBuckets(pub Vec<Bucket>);

impl TryFrom<Vec<String>> for TaggedBuckets {
    type Error = String;
    fn try_from(names: Vec<String>) -> Result<Self, String> {
        let why = "P's warp is in the output mapping, which takes the true error";
        buckets(names, &[Bucket::W, Bucket::C, Bucket::D], why).map(TaggedBuckets)
    }
}

fn tagged_buckets() -> TaggedBuckets {
    TaggedBuckets(vec![Bucket::W, Bucket::C, Bucket::D])
}

/// The scope filter of a list of buckets.
fn coverage(buckets: &[Bucket]) -> ScopeFilter {
    ScopeFilter::only(buckets.iter().map(|&b| BUCKET_NAMES[b as usize]))
}

fn feedback_alignment(s: FeedbackSettings, ctx: &RuleContext<'_>) -> Box<dyn LearningRule<f32>> {
    let scheme = match s.scheme {
        SchemeName::Random => FeedbackScheme::Random,
        SchemeName::Usf => FeedbackScheme::UniformSign,
        SchemeName::Brsf => FeedbackScheme::BatchRandomSign,
        SchemeName::Frsf => FeedbackScheme::FixedRandomSign,
    };
    let rule = FeedbackAlignment::scaled_to(ctx.draw_seed(s.feedback_seed), ctx.start)
        .with_scheme(scheme)
        .norm_matched(s.norm_matched)
        .sign_flipped(s.flip_sign)
        .covering(coverage(&s.buckets.0));
    Box::new(rule)
}

fn kolen_pollack(s: KolenPollackSettings, ctx: &RuleContext<'_>) -> Box<dyn LearningRule<f32>> {
    let scheme = FeedbackScheme::KolenPollack {
        learning_rate: s.learning_rate,
        weight_decay: s.weight_decay,
        optimizer: match s.optimizer {
            KpOptimizer::Adam => KolenPollackOptimizer::Adam,
            KpOptimizer::Sgd => KolenPollackOptimizer::Sgd,
        },
    };
    let rule = FeedbackAlignment::scaled_to(ctx.draw_seed(s.feedback_seed), ctx.start)
        .with_scheme(scheme)
        .covering(coverage(&s.buckets.0));
    Box::new(rule)
}

fn direct_feedback(s: DirectFeedbackSettings, ctx: &RuleContext<'_>) -> Box<dyn LearningRule<f32>> {
    let rule = DirectFeedbackAlignment::new(ctx.draw_seed(s.feedback_seed))
        .with_kernel_px(s.kernel_px.0)
        .covering(coverage(&s.buckets.0));
    Box::new(rule)
}

/// The built-in entries, in the order of the module table.
pub(super) fn entries() -> Vec<RuleEntry> {
    vec![
        RuleEntry::new(
            "backprop",
            "backprop: exact gradients",
            |_: NoSettings, _| Box::new(Backprop),
        ),
        RuleEntry::new(
            "feedback-alignment",
            "feedback alignment (Lillicrap et al. 2016): errors sent back through backward \
             weights B instead of W (random, or sign-concordant uSF/brSF/frSF), in the buckets \
             named (default D and P)",
            feedback_alignment,
        ),
        RuleEntry::new(
            "kolen-pollack",
            "Kolen-Pollack (Akrout et al. 2019): feedback alignment whose B learns from W's \
             gradient by its own optimiser (Adam by default), with weight decay on both",
            kolen_pollack,
        ),
        RuleEntry::new(
            "direct-feedback-alignment",
            "direct feedback alignment (Nøkland 2016): the prediction error sent to every layer \
             of decode by a fixed random k×k convolution per layer",
            direct_feedback,
        ),
        RuleEntry::new(
            "forward-forward",
            "forward-forward (Hinton 2022): layer-local objectives per bucket and per U-Net \
             block (right against wrong eye motion; with objective = \"prediction\", each \
             layer's prediction of the next ONS through a fixed random read-out) and a local \
             prediction objective for the re-encoder; no gradient between layers",
            |s: ForwardForwardSettings, _| {
                let objective = match s.objective {
                    ObjectiveName::Goodness => LocalObjective::Goodness,
                    ObjectiveName::Prediction => LocalObjective::Prediction,
                };
                Box::new(ForwardForward { objective })
            },
        ),
    ]
}
