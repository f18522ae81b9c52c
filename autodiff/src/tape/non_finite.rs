//! Where a non-finite value was first produced on a tape: the op and the scope (for the
//! cortex, the bucket) that made the first NaN or ±∞, forward or backward.
//!
//! A training loop that finds a non-finite loss or parameter gradient knows only *that* one
//! exists; the parameter it names is merely the first in id order. [`Tape::trace_non_finite`]
//! answers *where*: it scans the recorded values in recording order and, when they are all
//! finite, runs one more backprop sweep from the loss that checks every input gradient right
//! after the VJP that wrote it. The first node whose own output gradient was finite and
//! whose VJP made an input gradient non-finite is the producer. It is a diagnostic for the
//! moment training has already failed: the sweep allocates and checks every gradient.

use super::backward::NodeInputs;
use super::*;

/// Which pass produced a non-finite value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// The op's forward value.
    Forward,
    /// The op's vector–Jacobian product (an input gradient it wrote).
    Backward,
}

/// The node that first produced a non-finite value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NonFiniteSite {
    /// Position of the node on the tape.
    pub index: usize,
    /// The op's name (`"param"`, `"leaf"`, `"constant"` for data that was already non-finite).
    pub op: &'static str,
    /// The scope the node was recorded in ([`crate::scopes`]), if any.
    pub scope: Option<&'static str>,
    /// Forward value or backward VJP.
    pub pass: Pass,
}

impl std::fmt::Display for NonFiniteSite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let pass = match self.pass {
            Pass::Forward => "value",
            Pass::Backward => "backward (its VJP)",
        };
        write!(f, "op `{}` (node {}", self.op, self.index)?;
        if let Some(s) = self.scope {
            write!(f, ", scope {s}")?;
        }
        write!(f, "), in its {pass}")
    }
}

fn all_finite<T: Float>(t: &Tensor<T>) -> bool {
    t.data().iter().all(|v| v.is_finite())
}

impl<T: Float> Tape<T> {
    fn site(&self, index: usize, pass: Pass) -> NonFiniteSite {
        let node = &self.nodes[index];
        NonFiniteSite {
            index,
            op: match (&node.op, node.kind) {
                (Some(op), _) => op.name(),
                (None, NodeKind::Param(_)) => "param",
                (None, NodeKind::Leaf) => "leaf",
                (None, _) => "constant",
            },
            scope: self.scopes.name_of(index),
            pass,
        }
    }

    /// The first node, in recording order, whose value holds a NaN or ±∞.
    pub fn first_non_finite_value(&self) -> Option<NonFiniteSite> {
        (0..self.values.len())
            .find(|&i| !all_finite(&self.values[i]))
            .map(|i| self.site(i, Pass::Forward))
    }

    /// Where the first non-finite value of the step that ends in `loss` was produced: a
    /// forward value ([`Tape::first_non_finite_value`]) or, when every value is finite, the
    /// first VJP of a backprop sweep from `loss` that writes a non-finite input gradient.
    /// `None` when neither pass produces one (a learning rule's own backward did). The sweep
    /// replaces the gradients the tape holds.
    #[track_caller]
    pub fn trace_non_finite(&mut self, loss: Var) -> Option<NonFiniteSite> {
        if let Some(site) = self.first_non_finite_value() {
            return Some(site);
        }
        let last = self.check(loss);
        let seed = self.pool.copy_of(self.values[last].shape(), &[T::one()]);
        self.seed_grads(&[(loss, seed.clone())]);
        self.pool.put(seed);
        let mut scratch = NodeInputs::default();
        for i in (0..=last).rev() {
            let Some(dy) = self.grads[i].take() else {
                continue;
            };
            let inputs: Vec<usize> = {
                let r = &self.nodes[i].inputs;
                self.input_ids[r.start as usize..r.end as usize]
                    .iter()
                    .map(|&id| id as usize)
                    .collect()
            };
            self.backward_node(i, dy, &mut NoHooks, &mut scratch);
            let bad = inputs
                .iter()
                .any(|&j| self.grads[j].as_ref().is_some_and(|g| !all_finite(g)));
            if bad {
                return Some(self.site(i, Pass::Backward));
            }
        }
        None
    }
}
