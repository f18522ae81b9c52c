//! The reverse sweep of a [`Tape`]: seeding, one walk over the nodes in reverse, and the hooks
//! ([`BackwardHooks`]) through which a learning rule sees or replaces each node's
//! vector–Jacobian product.

use super::*;

/// What a backward hook sees of a node.
pub struct NodeView<'a, T: Float> {
    /// The node's handle.
    pub var: Var,
    /// The op's name, or `"constant"`, `"leaf"`, `"param"`.
    pub name: &'static str,
    /// What kind of node it is.
    pub kind: NodeKind,
    /// Handles of the inputs.
    pub inputs: &'a [Var],
    /// Kinds of the inputs (which are parameters, and which).
    pub input_kinds: &'a [NodeKind],
    /// Input values.
    pub input_values: &'a [&'a Tensor<T>],
    /// The node's value.
    pub value: &'a Tensor<T>,
    op: Option<&'a dyn Op<T>>,
    scopes: &'a Scopes,
}

impl<T: Float> NodeView<'_, T> {
    /// Indices of inputs the op declares as weights (see [`Op::weight_inputs`]).
    pub fn weight_inputs(&self) -> &'static [usize] {
        self.op.map_or(&[], |op| op.weight_inputs())
    }

    /// The scope this node was recorded in ([`crate::scopes`]).
    pub fn scope(&self) -> Option<&'static str> {
        self.scopes.name_of(self.var.index())
    }

    /// The scope input `i` was recorded in.
    pub fn input_scope(&self, i: usize) -> Option<&'static str> {
        self.scopes.name_of(self.inputs[i].index())
    }

    /// Runs this node's own backward with `inputs` substituted for the real input values, e.g.
    /// fixed random feedback weights in place of the forward weights.
    pub fn backward_with_inputs(
        &self,
        inputs: &[&Tensor<T>],
        dy: &Tensor<T>,
        dx: &mut GradSlots<'_, T>,
    ) {
        if let Some(op) = self.op {
            op.backward(
                &BackwardCx {
                    inputs,
                    output: self.value,
                    dy,
                },
                dx,
            );
        }
    }
}

/// Backward-time customisation: override a node's VJP, or see/modify a complete gradient.
pub trait BackwardHooks<T: Float> {
    /// Return `true` after writing this node's input gradients yourself; the op's own backward
    /// is then skipped. `dy` is the node's complete output gradient.
    fn override_vjp(
        &mut self,
        _node: &NodeView<'_, T>,
        _dy: &Tensor<T>,
        _dx: &mut GradSlots<'_, T>,
    ) -> bool {
        false
    }

    /// Called once per node whose gradient is complete, before it flows to the inputs. The
    /// gradient may be modified in place (clipping, scaling, logging, retaining a copy).
    fn on_grad(&mut self, _node: &NodeView<'_, T>, _grad: &mut Tensor<T>) {}
}

/// No hooks.
pub struct NoHooks;
impl<T: Float> BackwardHooks<T> for NoHooks {}

impl<T: Float> Tape<T> {
    /// Reverse-mode sweep from the scalar `loss` (seed 1).
    #[track_caller]
    pub fn backward(&mut self, loss: Var) {
        self.backward_with(loss, &mut NoHooks);
    }

    /// Reverse-mode sweep from the scalar `loss` with hooks.
    #[track_caller]
    pub fn backward_with(&mut self, loss: Var, hooks: &mut dyn BackwardHooks<T>) {
        let i = self.check(loss);
        assert_eq!(
            self.values[i].numel(),
            1,
            "backward: loss must have one element, got shape {:?}",
            self.values[i].shape()
        );
        let seed = self.pool.copy_of(self.values[i].shape(), &[T::one()]);
        let seeds = [(loss, seed)];
        self.backward_from(&seeds, hooks);
        // The seed was borrowed from the pool: give it back, or every backward leaks a buffer.
        let [(_, seed)] = seeds;
        self.pool.put(seed);
    }

    /// Reverse-mode sweep from several roots, each seeded with its own output gradient
    /// (forward-forward style local losses, or a VJP with a given cotangent).
    #[track_caller]
    pub fn backward_from(&mut self, seeds: &[(Var, Tensor<T>)], hooks: &mut dyn BackwardHooks<T>) {
        let last = self.seed_grads(seeds);
        let mut scratch = NodeInputs::default();
        let timed = !self.scopes.is_empty();
        for i in (0..=last).rev() {
            let Some(dy) = self.grads[i].take() else {
                continue;
            };
            let node_start = timed.then(std::time::Instant::now);
            self.backward_node(i, dy, hooks, &mut scratch);
            if let Some(t) = node_start {
                self.scopes.add_backward(i, t.elapsed().as_secs_f64());
            }
        }
    }

    /// Returns every gradient buffer to the pool, then adds each seed into its node's gradient;
    /// returns the highest seeded node index (the sweep starts there).
    #[track_caller]
    pub(super) fn seed_grads(&mut self, seeds: &[(Var, Tensor<T>)]) -> usize {
        for g in self.grads.iter_mut() {
            if let Some(g) = g.take() {
                self.pool.put(g);
            }
        }
        let mut last = 0;
        for (v, seed) in seeds {
            let i = self.check(*v);
            assert_eq!(
                self.values[i].shape(),
                seed.shape(),
                "backward_from: seed shape for node {i}"
            );
            let pool = &mut self.pool;
            let g = self.grads[i].get_or_insert_with(|| pool.zeros(seed.shape()));
            for (a, &b) in g.data_mut().iter_mut().zip(seed.data()) {
                *a += b;
            }
            last = last.max(i);
        }
        last
    }

    /// Propagates the output gradient `dy` of node `i` to its inputs: shows it to the hooks,
    /// runs the op's VJP (or the hooks' override) when an input wants a gradient, then keeps
    /// `dy` (leaves, parameters, retained nodes) or returns it to the pool.
    pub(super) fn backward_node(
        &mut self,
        i: usize,
        mut dy: Tensor<T>,
        hooks: &mut dyn BackwardHooks<T>,
        scratch: &mut NodeInputs,
    ) {
        let node = &self.nodes[i];
        let range = node.inputs.start as usize..node.inputs.end as usize;
        let ids = &self.input_ids[range];
        let wants = scratch.gather(ids, &self.nodes, &self.values, self.id, self.generation);
        let input_values: Vec<&Tensor<T>> =
            ids.iter().map(|&id| &self.values[id as usize]).collect();
        let view = NodeView {
            var: Var {
                tape: self.id,
                generation: self.generation,
                index: i as u32,
            },
            name: match (node.kind, &node.op) {
                (_, Some(op)) => op.name(),
                (NodeKind::Param(_), None) => "param",
                (NodeKind::Leaf, None) => "leaf",
                _ => "constant",
            },
            kind: node.kind,
            inputs: &scratch.vars,
            input_kinds: &scratch.kinds,
            input_values: &input_values,
            value: &self.values[i],
            op: node.op.as_deref(),
            scopes: &self.scopes,
        };
        hooks.on_grad(&view, &mut dy);
        if let (Some(op), true) = (node.op.as_deref(), wants != 0) {
            let mut dx = GradSlots {
                grads: &mut self.grads,
                input_ids: ids,
                input_shapes: &scratch.shapes,
                wants,
                pool: &mut self.pool,
            };
            let start = self.profile.is_some().then(std::time::Instant::now);
            if !hooks.override_vjp(&view, &dy, &mut dx) {
                let cx = BackwardCx {
                    inputs: &input_values,
                    output: &self.values[i],
                    dy: &dy,
                };
                op.backward(&cx, &mut dx);
            }
            if let (Some(p), Some(t)) = (&mut self.profile, start) {
                p.add_backward(op.name(), t.elapsed().as_secs_f64());
            }
        }
        let keep = node.retain || matches!(node.kind, NodeKind::Leaf | NodeKind::Param(_));
        if keep {
            self.grads[i] = Some(dy);
        } else {
            self.pool.put(dy);
        }
    }
}

/// Shapes, variables and kinds of one node's inputs, reused across the nodes of a backward
/// sweep so that it allocates once.
#[derive(Default)]
pub(super) struct NodeInputs {
    shapes: Vec<Shape>,
    vars: Vec<Var>,
    kinds: Vec<NodeKind>,
}

impl NodeInputs {
    /// Refills the lists for the inputs `ids`; returns the bit mask of the inputs that require a
    /// gradient (bit `k` for input `k`, the first 64 inputs).
    fn gather<T: Float>(
        &mut self,
        ids: &[u32],
        nodes: &[Node<T>],
        values: &[Tensor<T>],
        tape: u32,
        generation: u32,
    ) -> u64 {
        self.shapes.clear();
        self.vars.clear();
        self.kinds.clear();
        let mut wants = 0u64;
        for (k, &id) in ids.iter().enumerate() {
            let n = &nodes[id as usize];
            self.shapes.push(values[id as usize].shape());
            self.vars.push(Var {
                tape,
                generation,
                index: id,
            });
            self.kinds.push(n.kind);
            if n.requires_grad && k < 64 {
                wants |= 1 << k;
            }
        }
        wants
    }
}
