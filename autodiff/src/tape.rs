//! The tape: an append-only list of nodes that owns every value, and one reverse loop.
//!
//! - Recording an op appends a node (op, input ids, value). [`Var`] is a `Copy` handle to it.
//! - [`Tape::backward`] seeds `∂L/∂L = 1` and walks the nodes once in reverse; each node's
//!   gradient is complete when the walk reaches it (all consumers come later on the tape).
//! - [`Tape::clear`] forgets every node and returns all buffers to a pool keyed by length, so a
//!   training loop of fixed shapes allocates nothing after its first step. A `Var` from before
//!   `clear()` or from another tape panics with a clear message when used.
//! - Gradients of intermediate nodes are dropped as soon as they have been propagated, unless
//!   [`Tape::retain_grad`] asked for them; gradients of leaves (parameters, [`Tape::leaf`]) are
//!   always kept.
//! - A model may name stretches of the tape (scopes), tag activations and declare local losses
//!   ([`crate::scopes`]); learning rules read them, and backward times each scope.

use crate::op::{BackwardCx, ClosureOp, GradSlots, Op, Pointwise, PointwiseOp};
use crate::params::ParamId;
use crate::pool::BufferPool;
use crate::profile::Profile;
use crate::scopes::{ScopeTimes, Scopes};
use crate::{Float, Shape, Tensor};
use std::sync::atomic::{AtomicU32, Ordering};

mod backward;
mod non_finite;

pub use backward::{BackwardHooks, NoHooks, NodeView};
pub use non_finite::{NonFiniteSite, Pass};

static NEXT_TAPE_ID: AtomicU32 = AtomicU32::new(1);

/// A handle to a value on a tape. Cheap to copy; valid until the tape's next `clear()`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Var {
    tape: u32,
    generation: u32,
    index: u32,
}

impl Var {
    /// Position of the node on its tape (its order of recording).
    pub fn index(&self) -> usize {
        self.index as usize
    }
}

/// Whether and why a node takes part in backward.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// Data: no gradient flows into it.
    Constant,
    /// A leaf whose gradient is wanted ([`Tape::leaf`]).
    Leaf,
    /// A parameter leaf copied from a [`ParamStore`](crate::ParamStore).
    Param(ParamId),
    /// The output of an op.
    Op,
}

struct Node<T: Float> {
    op: Option<Box<dyn Op<T>>>,
    inputs: std::ops::Range<u32>,
    kind: NodeKind,
    requires_grad: bool,
    retain: bool,
}

/// An append-only record of a computation, owning every value. Generic over the scalar.
pub struct Tape<T: Float = f32> {
    id: u32,
    generation: u32,
    nodes: Vec<Node<T>>,
    input_ids: Vec<u32>,
    values: Vec<Tensor<T>>,
    grads: Vec<Option<Tensor<T>>>,
    pool: BufferPool<T>,
    /// Per-op times, when profiling is on (see [`crate::profile`]).
    profile: Option<Profile>,
    scopes: Scopes,
}

impl<T: Float> Default for Tape<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Float> Tape<T> {
    /// An empty tape.
    pub fn new() -> Self {
        Tape {
            id: NEXT_TAPE_ID.fetch_add(1, Ordering::Relaxed),
            generation: 0,
            nodes: Vec::new(),
            input_ids: Vec::new(),
            values: Vec::new(),
            grads: Vec::new(),
            pool: BufferPool::default(),
            profile: None,
            scopes: Scopes::default(),
        }
    }

    /// Forgets every node and recycles every buffer. Old `Var`s become invalid.
    pub fn clear(&mut self) {
        for v in self.values.drain(..) {
            self.pool.put(v);
        }
        for g in self.grads.drain(..).flatten() {
            self.pool.put(g);
        }
        self.nodes.clear();
        self.input_ids.clear();
        self.scopes.clear();
        self.generation = self.generation.wrapping_add(1);
    }

    /// Turns the per-op profile on or off (see [`crate::profile`]); turning it off drops what
    /// was collected.
    pub fn set_profiling(&mut self, on: bool) {
        self.profile = on.then(|| self.profile.take().unwrap_or_default());
    }

    /// The per-op times collected since profiling was turned on or last taken (empty when
    /// profiling is off); collection goes on from zero.
    pub fn take_profile(&mut self) -> Profile {
        match &mut self.profile {
            Some(p) => std::mem::take(p),
            None => Profile::default(),
        }
    }

    /// Nodes recorded from now on belong to scope `name` (see [`crate::scopes`]).
    pub fn enter_scope(&mut self, name: &'static str) {
        assert!(!name.is_empty(), "Tape::enter_scope: empty scope name");
        self.scopes.enter(self.nodes.len(), name);
    }

    /// Ends the current scope: nodes recorded from now on belong to none.
    pub fn close_scope(&mut self) {
        self.scopes.close(self.nodes.len());
    }

    /// The scope `v` was recorded in.
    #[track_caller]
    pub fn scope_of(&self, v: Var) -> Option<&'static str> {
        self.scopes.name_of(self.check(v))
    }

    /// Names the activation `v` (a layer's output) for learning rules that act on layers.
    #[track_caller]
    pub fn tag(&mut self, v: Var, name: &'static str) {
        self.check(v);
        self.scopes.tags.push((name, v));
    }

    /// The tagged activations, in recording order.
    pub fn tags(&self) -> &[(&'static str, Var)] {
        &self.scopes.tags
    }

    /// Declares the scalar `loss` as the local objective of scope `scope`.
    #[track_caller]
    pub fn declare_local_loss(&mut self, scope: &'static str, loss: Var) {
        let i = self.check(loss);
        assert_eq!(
            self.values[i].numel(),
            1,
            "declare_local_loss: the loss of scope {scope} must have one element, got {:?}",
            self.values[i].shape()
        );
        self.scopes.local_losses.push((scope, loss));
    }

    /// The declared local losses `(scope, loss)`, in recording order.
    pub fn local_losses(&self) -> &[(&'static str, Var)] {
        &self.scopes.local_losses
    }

    /// Forward and backward wall time per scope since the last `clear()`.
    pub fn scope_times(&self) -> ScopeTimes {
        self.scopes.times()
    }

    /// Number of nodes recorded since the last `clear()`.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when nothing is recorded.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The buffer pool (for ops that need scratch space during forward, and for statistics).
    pub fn pool(&mut self) -> &mut BufferPool<T> {
        &mut self.pool
    }

    /// A zeroed tensor from the pool, to fill and then pass to [`Tape::constant`].
    pub fn alloc(&mut self, shape: impl Into<Shape>) -> Tensor<T> {
        self.pool.zeros(shape.into())
    }

    #[track_caller]
    fn check(&self, v: Var) -> usize {
        assert!(
            v.tape == self.id,
            "Var {} belongs to tape #{}, used on tape #{}",
            v.index,
            v.tape,
            self.id
        );
        assert!(
            v.generation == self.generation,
            "Var {} is stale: recorded before Tape::clear() (generation {} vs {})",
            v.index,
            v.generation,
            self.generation
        );
        v.index as usize
    }

    fn push(
        &mut self,
        value: Tensor<T>,
        op: Option<Box<dyn Op<T>>>,
        inputs: &[u32],
        kind: NodeKind,
    ) -> Var {
        let requires_grad = match kind {
            NodeKind::Constant => false,
            NodeKind::Leaf | NodeKind::Param(_) => true,
            NodeKind::Op => inputs.iter().any(|&i| self.nodes[i as usize].requires_grad),
        };
        let start = self.input_ids.len() as u32;
        self.input_ids.extend_from_slice(inputs);
        let index = self.nodes.len() as u32;
        self.nodes.push(Node {
            op,
            inputs: start..self.input_ids.len() as u32,
            kind,
            requires_grad,
            retain: false,
        });
        self.values.push(value);
        self.grads.push(None);
        Var {
            tape: self.id,
            generation: self.generation,
            index,
        }
    }

    /// Records data that needs no gradient.
    pub fn constant(&mut self, value: Tensor<T>) -> Var {
        self.push(value, None, &[], NodeKind::Constant)
    }

    /// Records a copy of `data` with `shape` as a constant, reusing a pooled buffer.
    pub fn constant_from(&mut self, shape: impl Into<Shape>, data: &[T]) -> Var {
        let t = self.pool.copy_of(shape.into(), data);
        self.constant(t)
    }

    /// Records a leaf whose gradient [`Tape::backward`] computes and keeps.
    pub fn leaf(&mut self, value: Tensor<T>) -> Var {
        self.push(value, None, &[], NodeKind::Leaf)
    }

    /// Records a copy of parameter `id` (used by [`ParamStore::var`](crate::ParamStore::var)).
    pub fn param_leaf(&mut self, id: ParamId, value: &Tensor<T>, trainable: bool) -> Var {
        let t = self.pool.copy_of(value.shape(), value.data());
        let kind = if trainable {
            NodeKind::Param(id)
        } else {
            NodeKind::Constant
        };
        self.push(t, None, &[], kind)
    }

    /// Applies `op` to `inputs` and records the result.
    #[track_caller]
    pub fn apply(&mut self, mut op: impl Op<T>, inputs: &[Var]) -> Var {
        let mut ids = [0u32; 16];
        let mut heap;
        let ids: &mut [u32] = if inputs.len() <= 16 {
            &mut ids[..inputs.len()]
        } else {
            heap = vec![0u32; inputs.len()];
            &mut heap
        };
        for (slot, &v) in ids.iter_mut().zip(inputs) {
            *slot = self.check(v) as u32;
        }
        let out = {
            let input_values: Vec<&Tensor<T>> =
                ids.iter().map(|&i| &self.values[i as usize]).collect();
            let shape = op.output_shape(&input_values);
            let mut out = if op.overwrites_output() {
                self.pool.uninit(shape)
            } else {
                self.pool.zeros(shape)
            };
            let start = self.profile.is_some().then(std::time::Instant::now);
            op.forward(&input_values, &mut out);
            if let (Some(p), Some(t)) = (&mut self.profile, start) {
                p.add_forward(op.name(), t.elapsed().as_secs_f64());
            }
            out
        };
        let ids = ids.to_vec();
        self.push(out, Some(Box::new(op)), &ids, NodeKind::Op)
    }

    /// Applies a pointwise function with its derivative (see [`Pointwise`]).
    pub fn map(&mut self, p: impl Pointwise, x: Var) -> Var {
        self.apply(PointwiseOp(p), &[x])
    }

    /// Records `value` (computed by the caller from `inputs`) with a closure as its VJP.
    pub fn custom_vjp(
        &mut self,
        name: &'static str,
        inputs: &[Var],
        value: Tensor<T>,
        vjp: impl Fn(&BackwardCx<'_, T>, &mut GradSlots<'_, T>) + 'static,
    ) -> Var {
        self.apply(
            ClosureOp {
                name,
                value: Some(value),
                vjp: Box::new(vjp),
            },
            inputs,
        )
    }

    /// A copy of `x` through which no gradient flows.
    pub fn detach(&mut self, x: Var) -> Var {
        let i = self.check(x);
        let shape = self.values[i].shape();
        let t = {
            let (values, pool) = (&self.values, &mut self.pool);
            pool.copy_of(shape, values[i].data())
        };
        self.constant(t)
    }

    /// The value of `v`.
    #[track_caller]
    pub fn value(&self, v: Var) -> &Tensor<T> {
        &self.values[self.check(v)]
    }

    /// The shape of `v`.
    #[track_caller]
    pub fn shape(&self, v: Var) -> Shape {
        self.value(v).shape()
    }

    /// The kind of node `v` is.
    #[track_caller]
    pub fn kind(&self, v: Var) -> NodeKind {
        self.nodes[self.check(v)].kind
    }

    /// Asks backward to keep the gradient of the intermediate `v`.
    #[track_caller]
    pub fn retain_grad(&mut self, v: Var) {
        let i = self.check(v);
        self.nodes[i].retain = true;
    }

    /// `∂L/∂v` after [`Tape::backward`], if `v` is a leaf, a parameter or retained.
    #[track_caller]
    pub fn grad(&self, v: Var) -> Option<&Tensor<T>> {
        self.grads[self.check(v)].as_ref()
    }

    /// Parameter gradients of the last backward, `(id, ∂L/∂param)`, in recording order.
    pub fn param_grads(&self) -> impl Iterator<Item = (ParamId, &Tensor<T>)> {
        self.nodes
            .iter()
            .zip(&self.grads)
            .filter_map(|(n, g)| match (n.kind, g) {
                (NodeKind::Param(id), Some(g)) => Some((id, g)),
                _ => None,
            })
    }
}

#[cfg(test)]
mod tests;
