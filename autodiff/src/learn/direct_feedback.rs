//! Direct feedback alignment (Nøkland 2016, *NeurIPS*, arXiv:1609.01596): the output error
//! `e = ∂L/∂y` is sent straight to every tagged hidden layer through a fixed random
//! projection, `δh_k = B_k·e`, instead of travelling back through the layers above.
//!
//! Mechanics, on one reverse sweep from the loss:
//! - the model names its output ([`Objective::output`]) and tags its hidden activations
//!   ([`Tape::tag`]), one tag per layer; untagged nodes get their ordinary VJP;
//! - when the sweep reaches the output, its whole gradient `e` is kept (for an image
//!   predictor: the full error map, every pixel of every sample);
//! - when it reaches a tagged activation `h_k` recorded in a covered scope ([`ScopeFilter`]),
//!   the gradient is *replaced* by `B_k·e`; it then flows on through the layer's own ops, so
//!   the local derivative `f′(a_k)` and the layer's weights `dW_k = x_kᵀ·δa_k` are as in the
//!   paper, down to the next tagged activation below, where it is replaced again. The error
//!   the layers above would have sent into a covered tag is not computed at all (the op's VJP
//!   runs without that input; the tag then starts from zero before its replacement), so a
//!   step costs less than backprop's.
//! - Layers after the output's last tag (the output mapping, the loss) and tags in scopes not
//!   covered keep backprop: they take the true error, as the output layer does in the paper.
//!
//! The projections `B_k` (`project`: dense for `(B, features)` layers, a fixed random
//! `k × k` convolution of the resampled error for `(B, C, H, W)` layers, one per tag, rank
//! far above 1, scaled so each unit's feedback has the error's RMS) are drawn from a generator
//! seeded by the rule's seed and a hash of the tag and both shapes: they depend on nothing
//! trained. A tag used twice on one tape (a layer applied to two inputs) gets the same `B_k`
//! both times; distinct layers need distinct tags.
//!
//! Sign convention: what is returned is used like `∂L/∂θ` (optimisers subtract it).

mod project;

use super::{LearningRule, Objective, ParamGrads, RuleState, RuleStateError};
use crate::scopes::ScopeFilter;
use crate::tape::{BackwardHooks, NodeView};
use crate::{Float, GradSlots, ParamStore, Tape, Tensor};
use std::collections::{BTreeMap, HashMap};

/// A projection's key: tag, activation dims and output dims without the batch axis.
type Key = (&'static str, Vec<usize>, Vec<usize>);

/// Default side `k` of the image feedback kernels.
pub const DEFAULT_KERNEL_PX: usize = 3;

/// Direct feedback alignment with a fixed random projection per tagged layer.
pub struct DirectFeedbackAlignment<T: Float = f32> {
    seed: u64,
    kernel_px: usize,
    coverage: ScopeFilter,
    feedback: BTreeMap<Key, Tensor<T>>,
}

impl<T: Float> DirectFeedbackAlignment<T> {
    /// A rule whose projections are drawn from `seed`, with `k = DEFAULT_KERNEL_PX`, acting on
    /// every tag.
    pub fn new(seed: u64) -> Self {
        DirectFeedbackAlignment {
            seed,
            kernel_px: DEFAULT_KERNEL_PX,
            coverage: ScopeFilter::All,
            feedback: BTreeMap::new(),
        }
    }

    /// The same rule with `k × k` image feedback kernels (`k` odd).
    #[track_caller]
    pub fn with_kernel_px(mut self, k: usize) -> Self {
        assert!(
            k % 2 == 1,
            "DirectFeedbackAlignment: kernel side {k} must be odd"
        );
        self.kernel_px = k;
        self
    }

    /// The same rule replacing the gradients of tags recorded in the scopes `coverage` names
    /// only (backprop for the others).
    pub fn covering(mut self, coverage: ScopeFilter) -> Self {
        self.coverage = coverage;
        self
    }

    /// Writes `B·e` into `grad` (shape of the tagged activation).
    #[track_caller]
    pub fn project(&mut self, tag: &'static str, e: &Tensor<T>, grad: &mut Tensor<T>) {
        let (a, ed) = (grad.dims().to_vec(), e.dims().to_vec());
        assert_eq!(
            a[0], ed[0],
            "DirectFeedbackAlignment: tag {tag}: batch of activation {a:?} and output {ed:?}"
        );
        let key = (tag, a[1..].to_vec(), ed[1..].to_vec());
        let (seed, k) = (self.seed, self.kernel_px);
        let b = self
            .feedback
            .entry(key)
            .or_insert_with_key(|(tag, a, e)| project::draw(tag, a, e, k, seed));
        if a.len() == 2 {
            project::dense(b, e, grad);
        } else {
            let e_hat = project::resample(tag, e, a[2], a[3]);
            project::convolve(b, &e_hat, grad);
        }
    }
}

struct Hooks<'a, T: Float> {
    rule: &'a mut DirectFeedbackAlignment<T>,
    output: usize,
    tags: HashMap<usize, &'static str>,
    error: Option<Tensor<T>>,
}

impl<T: Float> Hooks<'_, T> {
    /// Whether the gradient of node `index` (recorded in `scope`) will be replaced.
    fn replaced(&self, index: usize, scope: Option<&str>) -> bool {
        self.error.is_some() && self.tags.contains_key(&index) && self.rule.coverage.covers(scope)
    }
}

impl<T: Float> BackwardHooks<T> for Hooks<'_, T> {
    fn on_grad(&mut self, node: &NodeView<'_, T>, grad: &mut Tensor<T>) {
        let i = node.var.index();
        if i == self.output {
            self.error = Some(grad.clone());
        } else if self.replaced(i, node.scope()) {
            let e = self.error.take().expect("replaced implies an error");
            self.rule.project(self.tags[&i], &e, grad);
            self.error = Some(e);
        }
    }

    fn override_vjp(
        &mut self,
        node: &NodeView<'_, T>,
        dy: &Tensor<T>,
        dx: &mut GradSlots<'_, T>,
    ) -> bool {
        let n = dx.len().min(64);
        let skip: Vec<usize> = (0..n)
            .filter(|&i| dx.wants(i) && self.replaced(node.inputs[i].index(), node.input_scope(i)))
            .collect();
        if skip.is_empty() {
            return false;
        }
        for &i in &skip {
            // A zero gradient, so the sweep still reaches the tag and replaces it.
            dx.slot(i);
            dx.set_wanted(i, false);
        }
        node.backward_with_inputs(node.input_values, dy, dx);
        for &i in &skip {
            dx.set_wanted(i, true);
        }
        true
    }
}

impl<T: Float> LearningRule<T> for DirectFeedbackAlignment<T> {
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        let output = objective.output.expect(
            "DirectFeedbackAlignment: the objective names no output (Objective::with_output)",
        );
        let tags = tape
            .tags()
            .iter()
            .map(|&(name, v)| (v.index(), name))
            .collect();
        let mut hooks = Hooks {
            rule: self,
            output: output.index(),
            tags,
            error: None,
        };
        tape.backward_with(objective.loss, &mut hooks);
        grads.fill_from_tape(tape);
    }

    fn state(&self, _params: &ParamStore<T>) -> RuleState<T> {
        let mut s = RuleState::new();
        for ((tag, a, e), b) in &self.feedback {
            s.tensors.insert(state_key(tag, a, e), b.clone());
        }
        s
    }

    fn load_state(
        &mut self,
        state: &RuleState<T>,
        _params: &ParamStore<T>,
    ) -> Result<(), RuleStateError> {
        let mut feedback = BTreeMap::new();
        for (key, b) in &state.tensors {
            let bad = || RuleStateError::Unexpected {
                key: key.clone(),
                reason: "not `feedback|tag|activation dims|output dims`".into(),
            };
            let parts: Vec<&str> = key.split('|').collect();
            let [_, tag, a, e] = parts[..] else {
                return Err(bad());
            };
            let dims =
                |s: &str| -> Option<Vec<usize>> { s.split('x').map(|d| d.parse().ok()).collect() };
            let (a, e) = (dims(a).ok_or_else(bad)?, dims(e).ok_or_else(bad)?);
            feedback.insert((crate::scopes::intern(tag), a, e), b.clone());
        }
        if let Some(k) = state.metadata.keys().next() {
            return Err(state.unexpected(&format!("direct feedback alignment ({k})")));
        }
        self.feedback = feedback;
        Ok(())
    }
}

/// `feedback|tag|8x32x32|1x64x64`.
fn state_key(tag: &str, a: &[usize], e: &[usize]) -> String {
    let dims = |d: &[usize]| {
        d.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join("x")
    };
    format!("feedback|{tag}|{}|{}", dims(a), dims(e))
}

#[cfg(test)]
mod tests;
