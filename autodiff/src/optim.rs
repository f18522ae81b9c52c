//! Optimisers: pure per-parameter update rules ([`UpdateRule`]: [`Sgd`], [`Adam`]) and the
//! container that applies one to a [`ParamStore`] ([`Optimizer`]).
//!
//! - **Sign.** Gradients are `∂L/∂θ` ([`ParamGrads`]); rules *subtract* them.
//! - **Learning rate.** The caller gives it to every [`Optimizer::step`] (a schedule decides
//!   it, step by step); no rule or optimiser keeps one of its own. A parameter's rate is that
//!   rate times its scale ([`Optimizer::set_lr_scale`], 1 unless set).
//! - **Frozen parameters** are skipped entirely: no update, no state change, even when a
//!   gradient for them is present.
//! - **Steps** are counted per parameter (Adam's bias correction uses the number of updates that
//!   parameter received), as PyTorch does.
//! - **State** is a list of named tensors per parameter (Adam: `m`, `v`), created as zeros on the
//!   first update. For checkpoints, [`Optimizer::state_tensors`] names them
//!   `"{param}::{rule}.{slot}"` (e.g. `"unet.conv0::adam.m"`) and [`Optimizer::state_metadata`]
//!   records each parameter's step as `"{param}::{rule}.step"`; [`Optimizer::load_state`]
//!   restores both, so a resumed run continues bit-identically. [`Optimizer::save_safetensors`]
//!   and [`Optimizer::load_safetensors`] do this through a file of their own.

mod rules;

pub use rules::{Adam, Sgd};

use crate::learn::ParamGrads;
use crate::params::{read_safetensors, write_safetensors, SafetensorsError};
use crate::{Float, ParamId, ParamStore, Tensor};
use std::collections::BTreeMap;
use std::path::Path;

/// A per-parameter update: what a user implements to add an optimiser.
pub trait UpdateRule<T: Float> {
    /// Short name used in state keys (`"adam"`).
    fn name(&self) -> &'static str;
    /// Names of the state tensors kept per parameter, each shaped like the parameter.
    fn slots(&self) -> &'static [&'static str];
    /// Updates `p` in place from its gradient `g`, state `slots` (in the order of
    /// [`UpdateRule::slots`]) and `step`, the 1-based count of updates of this parameter, at
    /// learning rate `lr` (the step's rate times this parameter's scale,
    /// [`Optimizer::set_lr_scale`]).
    fn update(&self, p: &mut [T], g: &[T], slots: &mut [Tensor<T>], step: u64, lr: f64);
}

/// Why an optimiser step or a state load failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OptimError {
    /// A gradient's shape differs from its parameter's.
    #[error("optimiser: gradient of {name:?} has shape {grad:?}, parameter has {param:?}")]
    GradShape {
        name: String,
        param: Vec<usize>,
        grad: Vec<usize>,
    },
    /// A gradient refers to a parameter the store does not have.
    #[error("optimiser: gradient for unknown parameter id {0:?}")]
    UnknownParam(ParamId),
    /// Strict mode: a trainable parameter received no gradient.
    #[error("optimiser (strict): trainable parameter {name:?} has no gradient")]
    MissingGrad { name: String },
    /// Loaded state does not fit (missing key, wrong shape, unparsable step).
    #[error("optimiser state: {key:?}: {reason}")]
    State { key: String, reason: String },
    /// Reading or writing a state file failed.
    #[error(transparent)]
    Io(Box<SafetensorsError>),
}

impl From<SafetensorsError> for OptimError {
    fn from(e: SafetensorsError) -> Self {
        OptimError::Io(Box::new(e))
    }
}

struct State<T> {
    step: u64,
    slots: Vec<Tensor<T>>,
}

/// Applies an [`UpdateRule`] to the trainable parameters of a store, keeping per-parameter state.
pub struct Optimizer<T: Float, R: UpdateRule<T>> {
    /// The rule (its hyper-parameters, e.g. `opt.rule.beta1`, may be changed between steps).
    pub rule: R,
    /// Error when a trainable parameter has no gradient (catches unused parameters).
    pub strict: bool,
    states: BTreeMap<ParamId, State<T>>,
    lr_scales: BTreeMap<ParamId, f64>,
}

impl<T: Float, R: UpdateRule<T>> Optimizer<T, R> {
    /// An optimiser with no state yet.
    pub fn new(rule: R) -> Self {
        Optimizer {
            rule,
            strict: false,
            states: BTreeMap::new(),
            lr_scales: BTreeMap::new(),
        }
    }

    /// Multiplies the learning rate of parameter `id` by `scale` from the next step on (0
    /// holds it).
    pub fn set_lr_scale(&mut self, id: ParamId, scale: f64) {
        self.lr_scales.insert(id, scale);
    }

    /// Updates every trainable parameter that has a gradient in `grads`, at `learning_rate`
    /// (times each parameter's scale).
    pub fn step(
        &mut self,
        learning_rate: f64,
        params: &mut ParamStore<T>,
        grads: &ParamGrads<T>,
    ) -> Result<(), OptimError> {
        for (id, g) in grads.iter() {
            if id.0 as usize >= params.len() {
                return Err(OptimError::UnknownParam(id));
            }
            let p = params.get(id);
            if p.shape() != g.shape() {
                return Err(OptimError::GradShape {
                    name: params.name(id).into(),
                    param: p.dims().to_vec(),
                    grad: g.dims().to_vec(),
                });
            }
        }
        if self.strict {
            if let Some(id) = params
                .ids()
                .find(|&id| params.is_trainable(id) && grads.get(id).is_none())
            {
                return Err(OptimError::MissingGrad {
                    name: params.name(id).into(),
                });
            }
        }
        let n_slots = self.rule.slots().len();
        for (id, g) in grads.iter() {
            if !params.is_trainable(id) {
                continue;
            }
            let shape = params.get(id).shape();
            let st = self.states.entry(id).or_insert_with(|| State {
                step: 0,
                slots: (0..n_slots).map(|_| Tensor::zeros(shape)).collect(),
            });
            st.step += 1;
            self.rule.update(
                params.get_mut(id).data_mut(),
                g.data(),
                &mut st.slots,
                st.step,
                learning_rate * self.lr_scales.get(&id).copied().unwrap_or(1.0),
            );
        }
        Ok(())
    }

    /// Number of updates parameter `id` has received.
    pub fn step_count(&self, id: ParamId) -> u64 {
        self.states.get(&id).map_or(0, |s| s.step)
    }

    /// Forgets all state (as if newly created).
    pub fn reset(&mut self) {
        self.states.clear();
    }

    fn key(&self, params: &ParamStore<T>, id: ParamId, what: &str) -> String {
        format!("{}::{}.{what}", params.name(id), self.rule.name())
    }

    /// The state tensors, named `"{param}::{rule}.{slot}"`.
    pub fn state_tensors(&self, params: &ParamStore<T>) -> Vec<(String, &Tensor<T>)> {
        let names = self.rule.slots();
        let mut out = Vec::new();
        for (&id, st) in &self.states {
            for (slot, t) in names.iter().zip(&st.slots) {
                out.push((self.key(params, id, slot), t));
            }
        }
        out
    }

    /// The per-parameter step counts, as `"{param}::{rule}.step" → "n"`.
    pub fn state_metadata(&self, params: &ParamStore<T>) -> BTreeMap<String, String> {
        self.states
            .iter()
            .map(|(&id, st)| (self.key(params, id, "step"), st.step.to_string()))
            .collect()
    }

    /// Restores state saved by [`Optimizer::state_tensors`] and [`Optimizer::state_metadata`]
    /// for the same store layout (matched by parameter name). Parameters without a saved step
    /// start fresh. Unrelated tensors and keys (e.g. the parameters themselves) are ignored.
    pub fn load_state(
        &mut self,
        params: &ParamStore<T>,
        tensors: &BTreeMap<String, Tensor<T>>,
        metadata: &BTreeMap<String, String>,
    ) -> Result<(), OptimError> {
        let mut states = BTreeMap::new();
        for id in params.ids() {
            let key = self.key(params, id, "step");
            let Some(step) = metadata.get(&key) else {
                continue;
            };
            let step = step.parse::<u64>().map_err(|e| OptimError::State {
                key: key.clone(),
                reason: e.to_string(),
            })?;
            let mut slots = Vec::new();
            for slot in self.rule.slots() {
                let key = self.key(params, id, slot);
                let t = tensors.get(&key).ok_or_else(|| OptimError::State {
                    key: key.clone(),
                    reason: "missing".into(),
                })?;
                if t.shape() != params.get(id).shape() {
                    let reason = format!(
                        "shape {:?}, parameter has {:?}",
                        t.shape(),
                        params.get(id).shape()
                    );
                    return Err(OptimError::State { key, reason });
                }
                slots.push(t.clone());
            }
            states.insert(id, State { step, slots });
        }
        self.states = states;
        Ok(())
    }

    /// Writes the state to its own safetensors file (atomically).
    pub fn save_safetensors(
        &self,
        path: impl AsRef<Path>,
        params: &ParamStore<T>,
    ) -> Result<(), OptimError> {
        let named = self.state_tensors(params);
        let tensors: Vec<(&str, &Tensor<T>)> =
            named.iter().map(|(n, t)| (n.as_str(), *t)).collect();
        Ok(write_safetensors(
            path.as_ref(),
            &tensors,
            &self.state_metadata(params),
        )?)
    }

    /// Restores the state from a file written by [`Optimizer::save_safetensors`].
    pub fn load_safetensors(
        &mut self,
        path: impl AsRef<Path>,
        params: &ParamStore<T>,
    ) -> Result<(), OptimError> {
        let loaded = read_safetensors::<T>(path.as_ref())?;
        self.load_state(params, &loaded.tensors, &loaded.metadata)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup() -> (ParamStore<f32>, ParamGrads<f32>) {
        let mut params = ParamStore::new();
        let a = params.add("a", Tensor::from_vec([2], vec![1.0, -1.0]));
        let b = params.add("b", Tensor::from_vec([1], vec![0.5]));
        let mut grads = ParamGrads::new();
        grads.insert(a, Tensor::from_vec([2], vec![0.3, -0.2]));
        grads.insert(b, Tensor::from_vec([1], vec![1.0]));
        (params, grads)
    }

    #[test]
    fn frozen_parameters_and_their_state_are_untouched() {
        let (mut params, grads) = setup();
        params.freeze(ParamId(1));
        let mut opt = Optimizer::new(Adam::default());
        for _ in 0..3 {
            opt.step(0.1, &mut params, &grads).unwrap();
        }
        assert_eq!(params.get(ParamId(1)).data()[0].to_bits(), 0.5f32.to_bits());
        assert_eq!(
            (opt.step_count(ParamId(0)), opt.step_count(ParamId(1))),
            (3, 0)
        );
        assert!(params.get(ParamId(0)).data()[0] < 1.0);
    }

    #[test]
    fn resumed_adam_continues_bit_identically() {
        // Gradients that change size and sign, so Adam's moments matter.
        let grads_at = |k: usize| {
            let (_, mut g) = setup();
            g.scale((k as f64 * 1.7).sin() * (1.0 + k as f64));
            g
        };
        let (mut p1, _) = setup();
        let mut o1 = Optimizer::new(Adam::default());
        o1.step(0.05, &mut p1, &grads_at(0)).unwrap();
        o1.step(0.05, &mut p1, &grads_at(1)).unwrap();
        let path =
            std::env::temp_dir().join(format!("autodiff-optim-{}.safetensors", std::process::id()));
        o1.save_safetensors(&path, &p1).unwrap();
        let copy = |p: &ParamStore<f32>| {
            let mut q = ParamStore::new();
            p.ids().for_each(|id| {
                q.add(p.name(id), p.get(id).clone());
            });
            q
        };
        let (mut p2, mut p3) = (copy(&p1), copy(&p1));
        let mut o2 = Optimizer::new(Adam::default());
        o2.load_safetensors(&path, &p2).unwrap();
        std::fs::remove_file(&path).unwrap();
        let mut fresh = Optimizer::new(Adam::default());
        for k in 2..5 {
            let g = grads_at(k);
            o1.step(0.05, &mut p1, &g).unwrap();
            o2.step(0.05, &mut p2, &g).unwrap();
            fresh.step(0.05, &mut p3, &g).unwrap();
        }
        for id in p1.ids() {
            assert_eq!(p1.get(id), p2.get(id), "{}", p1.name(id));
        }
        assert_ne!(
            p1.get(ParamId(0)),
            p3.get(ParamId(0)),
            "state matters, so the test can fail"
        );
        assert_eq!(o2.step_count(ParamId(0)), 5);
    }

    #[test]
    fn shape_mismatch_and_strict_mode_are_errors() {
        let (mut params, mut grads) = setup();
        grads.insert(ParamId(1), Tensor::zeros([2]));
        let mut opt = Optimizer::new(Sgd::default());
        let err = opt.step(0.1, &mut params, &grads).unwrap_err();
        assert!(
            err.to_string()
                .contains("\"b\" has shape [2], parameter has [1]"),
            "{err}"
        );
        grads.remove(ParamId(1));
        opt.strict = true;
        assert!(matches!(
            opt.step(0.1, &mut params, &grads),
            Err(OptimError::MissingGrad { .. })
        ));
        assert_eq!(
            params.get(ParamId(0)).data(),
            &[1.0, -1.0],
            "nothing applied on error"
        );
    }
}
