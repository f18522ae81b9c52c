//! Alignment with backprop as a measurement: how a rule's update relates to the exact
//! gradient on the same recorded step.
//!
//! After a rule has assigned credit, [`AlignmentMeter::measure`] runs one more backprop sweep
//! from the loss on the *same* tape (the forward values are still there; the sweep replaces
//! the tape's gradients, not the rule's [`ParamGrads`]) and compares, for each group of
//! parameters (a layer, a bucket), the rule's update `u` with backprop's gradient `g`:
//!
//! - `cosine = ⟨u, g⟩ / (‖u‖·‖g‖)` over the group's concatenated entries: 1 when the rule
//!   points where backprop does, 0 when it is orthogonal, negative when it climbs the loss
//!   (the mean angle is `acos` of it); `None` when either norm is zero;
//! - `rule_norm = ‖u‖`, `backprop_norm = ‖g‖` (Frobenius, over the group).
//!
//! Sums run in f64 in parameter-id order. The sweep costs one backward pass; measure every
//! N steps, not every step.

use super::ParamGrads;
use crate::{Float, ParamId, Tape, Var};

/// A rule's update against backprop's gradient over one group of parameters (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroupAlignment {
    /// `⟨u, g⟩ / (‖u‖·‖g‖)`, `None` when a norm is zero.
    pub cosine: Option<f64>,
    /// `‖u‖`.
    pub rule_norm: f64,
    /// `‖g‖`.
    pub backprop_norm: f64,
}

impl GroupAlignment {
    /// The angle between the two, in degrees (`None` when the cosine is).
    pub fn angle_degrees(&self) -> Option<f64> {
        self.cosine.map(|c| c.clamp(-1.0, 1.0).acos().to_degrees())
    }
}

/// Compares `rule` with `exact` over the parameters `ids` (absent entries count as zero).
pub fn compare<T: Float>(
    rule: &ParamGrads<T>,
    exact: &ParamGrads<T>,
    ids: impl IntoIterator<Item = ParamId>,
) -> GroupAlignment {
    let (mut dot, mut uu, mut gg) = (0.0, 0.0, 0.0);
    for id in ids {
        let (u, g) = (rule.get(id), exact.get(id));
        if let Some(u) = u {
            uu += u.sum_sq();
        }
        if let Some(g) = g {
            gg += g.sum_sq();
        }
        if let (Some(u), Some(g)) = (u, g) {
            dot += (u.data().iter().zip(g.data()))
                .map(|(a, b)| a.as_f64() * b.as_f64())
                .sum::<f64>();
        }
    }
    let (rule_norm, backprop_norm) = (uu.sqrt(), gg.sqrt());
    let cosine =
        (rule_norm > 0.0 && backprop_norm > 0.0).then(|| dot / (rule_norm * backprop_norm));
    GroupAlignment {
        cosine,
        rule_norm,
        backprop_norm,
    }
}

/// Measures a rule's update against backprop's gradient, reusing its buffers across calls.
#[derive(Default)]
pub struct AlignmentMeter<T: Float = f32> {
    exact: ParamGrads<T>,
}

impl<T: Float> AlignmentMeter<T> {
    /// A meter with no buffers yet.
    pub fn new() -> Self {
        AlignmentMeter {
            exact: ParamGrads::new(),
        }
    }

    /// Runs a backprop sweep from `loss` on `tape` and compares `rule` with it for each of
    /// `groups` groups; `group_of` puts a parameter in a group (or in none). A group with no
    /// parameter gives `None`.
    pub fn measure(
        &mut self,
        tape: &mut Tape<T>,
        loss: Var,
        rule: &ParamGrads<T>,
        groups: usize,
        group_of: impl Fn(ParamId) -> Option<usize>,
    ) -> Vec<Option<GroupAlignment>> {
        tape.backward(loss);
        self.exact.fill_from_tape(tape);
        let mut members: Vec<Vec<ParamId>> = vec![Vec::new(); groups];
        let ids: std::collections::BTreeSet<ParamId> = (rule.iter().map(|(id, _)| id))
            .chain(self.exact.iter().map(|(id, _)| id))
            .collect();
        for id in ids {
            if let Some(k) = group_of(id).filter(|&k| k < groups) {
                members[k].push(id);
            }
        }
        members
            .into_iter()
            .map(|ids| (!ids.is_empty()).then(|| compare(rule, &self.exact, ids)))
            .collect()
    }

    /// Backprop's gradients of the last [`AlignmentMeter::measure`].
    pub fn backprop(&self) -> &ParamGrads<T> {
        &self.exact
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::{Backprop, FeedbackAlignment, LearningRule};
    use crate::{ParamStore, Tensor};

    #[test]
    fn backprop_is_aligned_with_itself_and_feedback_alignment_is_not_exactly() {
        let mut p = ParamStore::<f64>::new();
        p.add("a", Tensor::from_fn([3, 4], |i| (i as f64 * 0.61).sin()));
        p.add("b", Tensor::from_fn([4, 2], |i| (i as f64 * 0.37).cos()));
        let record = |tape: &mut Tape<f64>| {
            tape.clear();
            let x = tape.constant(Tensor::from_fn([6, 3], |i| (i as f64 * 0.29).sin()));
            let (a, b) = (p.var(tape, ParamId(0)), p.var(tape, ParamId(1)));
            let h = tape.matmul(x, a);
            let h = tape.tanh(h);
            let y = tape.matmul(h, b);
            let y = tape.square(y);
            tape.sum(y)
        };
        let mut tape = Tape::new();
        let mut meter = AlignmentMeter::new();
        for (rule, exact) in [
            (Box::new(Backprop) as Box<dyn LearningRule<f64>>, true),
            (Box::new(FeedbackAlignment::new(3)), false),
        ] {
            let mut rule = rule;
            let loss = record(&mut tape);
            let g = rule.assign_credit(&mut tape, loss.into(), &p);
            let a = meter.measure(&mut tape, loss, &g, 3, |id| Some(id.0 as usize));
            assert!(a[2].is_none(), "an empty group");
            let (hidden, out) = (a[0].unwrap(), a[1].unwrap());
            assert!(
                (out.cosine.unwrap() - 1.0).abs() < 1e-12,
                "output layer exact"
            );
            assert!((out.rule_norm - out.backprop_norm).abs() < 1e-12);
            let c = hidden.cosine.unwrap();
            assert_eq!((c - 1.0).abs() < 1e-12, exact, "hidden cosine {c}");
            assert!((-1.0..=1.0 + 1e-12).contains(&c));
        }
        let zero = compare(&ParamGrads::<f64>::new(), meter.backprop(), [ParamId(0)]);
        assert_eq!(zero.cosine, None);
        assert_eq!(zero.rule_norm, 0.0);
    }
}
