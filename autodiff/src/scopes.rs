//! Scopes, tags and local losses: what a model declares about its recorded forward pass, so a
//! learning rule can find its layers and a profiler can split the time.
//!
//! - A **scope** is a named stretch of the tape: [`Tape::enter_scope`](crate::Tape::enter_scope)
//!   makes every node recorded afterwards belong to it, until the next `enter_scope` or
//!   [`Tape::close_scope`](crate::Tape::close_scope). A name may be entered many times (the
//!   cortex's W decodes at the start and encodes at the end); times add up per name. Nodes
//!   recorded before the first scope belong to none.
//! - A **tag** names one activation (a layer's output) for rules that act on layers, such as
//!   direct feedback alignment ([`crate::learn::DirectFeedbackAlignment`]).
//! - A **local loss** is a scalar a model declares for one scope, for rules that train layers
//!   from their own objectives, such as forward-forward ([`crate::learn::ForwardForward`]).
//!
//! - A **scope filter** ([`ScopeFilter`]) names the scopes a learning rule acts in; a name
//!   covers its sub-scopes too (`"D"` covers `"D.inc"`), so a model may split a bucket into
//!   blocks and still be addressed by bucket.
//!
//! Scope and tag names are `&'static str`; a model that builds them at run time (one per
//! layer of a network of configurable depth) gets them from [`intern`], which keeps one copy
//! of each distinct name for the life of the process.
//!
//! Forward time per scope is wall clock between scope entries (ops run as they are recorded);
//! backward time per scope is the wall clock of each reverse-loop iteration, hooks included,
//! charged to the node's scope, summed over every sweep since the last `clear()`. Units: ms.
//! Everything here is forgotten by [`Tape::clear`](crate::Tape::clear).

use crate::Var;
use std::collections::BTreeSet;
use std::sync::Mutex;
use std::time::Instant;

/// A `&'static str` equal to `name`, one allocation per distinct name for the whole process
/// (names of scopes and tags built at run time, e.g. `"d.down1.conv0"`).
pub fn intern(name: &str) -> &'static str {
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(&known) = names.get(name) {
        return known;
    }
    let leaked: &'static str = Box::leak(name.to_string().into_boxed_str());
    names.insert(leaked);
    leaked
}

/// The scopes a learning rule acts in (see the module docs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum ScopeFilter {
    /// Every node, in a scope or not.
    #[default]
    All,
    /// Nodes recorded in one of these scopes or their sub-scopes (`name` or `name.…`).
    Only(Vec<String>),
}

impl ScopeFilter {
    /// The filter covering `names` (and their sub-scopes).
    pub fn only<S: Into<String>>(names: impl IntoIterator<Item = S>) -> Self {
        ScopeFilter::Only(names.into_iter().map(Into::into).collect())
    }

    /// Whether a node recorded in `scope` is covered.
    pub fn covers(&self, scope: Option<&str>) -> bool {
        match (self, scope) {
            (ScopeFilter::All, _) => true,
            (ScopeFilter::Only(_), None) => false,
            (ScopeFilter::Only(names), Some(s)) => names.iter().any(|n| {
                s.strip_prefix(n.as_str())
                    .is_some_and(|rest| rest.is_empty() || rest.starts_with('.'))
            }),
        }
    }
}

/// Scopes, tags and local losses of one recording (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct Scopes {
    /// `(first node index, name, entry time)`, in recording order.
    starts: Vec<(usize, &'static str, Instant)>,
    /// When the last stretch ended, once closed.
    end: Option<Instant>,
    /// Backward seconds per entry of `starts`.
    backward_s: Vec<f64>,
    pub(crate) tags: Vec<(&'static str, Var)>,
    pub(crate) local_losses: Vec<(&'static str, Var)>,
}

/// Wall time per scope name, in order of first entry (ms).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScopeTimes {
    /// `(scope, forward ms)`.
    pub forward_ms: Vec<(&'static str, f64)>,
    /// `(scope, backward ms)`, over every sweep since the last `clear()`.
    pub backward_ms: Vec<(&'static str, f64)>,
}

impl ScopeTimes {
    /// Forward ms of scope `name` (0 when absent).
    pub fn forward(&self, name: &str) -> f64 {
        self.forward_ms
            .iter()
            .filter(|(n, _)| *n == name)
            .map(|x| x.1)
            .sum()
    }

    /// Backward ms of scope `name` (0 when absent).
    pub fn backward(&self, name: &str) -> f64 {
        self.backward_ms
            .iter()
            .filter(|(n, _)| *n == name)
            .map(|x| x.1)
            .sum()
    }
}

impl Scopes {
    pub(crate) fn clear(&mut self) {
        self.starts.clear();
        self.backward_s.clear();
        self.end = None;
        self.tags.clear();
        self.local_losses.clear();
    }

    pub(crate) fn enter(&mut self, first_node: usize, name: &'static str) {
        self.starts.push((first_node, name, Instant::now()));
        self.backward_s.push(0.0);
        self.end = None;
    }

    pub(crate) fn close(&mut self, first_node: usize) {
        self.enter(first_node, "");
        self.end = Some(Instant::now());
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.starts.is_empty()
    }

    /// Index into `starts` of the stretch holding node `index`.
    fn entry_of(&self, index: usize) -> Option<usize> {
        let k = self.starts.partition_point(|(start, _, _)| *start <= index);
        (k > 0 && !self.starts[k - 1].1.is_empty()).then(|| k - 1)
    }

    pub(crate) fn name_of(&self, index: usize) -> Option<&'static str> {
        self.entry_of(index).map(|k| self.starts[k].1)
    }

    pub(crate) fn add_backward(&mut self, index: usize, seconds: f64) {
        if let Some(k) = self.entry_of(index) {
            self.backward_s[k] += seconds;
        }
    }

    pub(crate) fn times(&self) -> ScopeTimes {
        let mut t = ScopeTimes::default();
        let add = |v: &mut Vec<(&'static str, f64)>, name: &'static str, ms: f64| match v
            .iter_mut()
            .find(|(n, _)| *n == name)
        {
            Some(e) => e.1 += ms,
            None => v.push((name, ms)),
        };
        for (k, &(_, name, at)) in self.starts.iter().enumerate() {
            if name.is_empty() {
                continue;
            }
            let next = self.starts.get(k + 1).map(|s| s.2).or(self.end);
            let fwd = next.map_or(0.0, |n| (n - at).as_secs_f64() * 1e3);
            add(&mut t.forward_ms, name, fwd);
            add(&mut t.backward_ms, name, self.backward_s[k] * 1e3);
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::{intern, ScopeFilter};
    use crate::{Tape, Tensor};

    #[test]
    fn a_filter_covers_its_scopes_and_their_sub_scopes_only() {
        let f = ScopeFilter::only(["D", "P"]);
        assert!(f.covers(Some("D")) && f.covers(Some("D.inc")) && f.covers(Some("P")));
        assert!(!f.covers(Some("Dx")) && !f.covers(Some("W")) && !f.covers(None));
        assert!(ScopeFilter::All.covers(None) && ScopeFilter::All.covers(Some("W")));
        let a = intern(&format!("{}.{}", "d", "inc"));
        assert_eq!(a, "d.inc");
        assert!(std::ptr::eq(a, intern("d.inc")), "one copy per name");
    }

    #[test]
    fn nodes_belong_to_the_scope_they_were_recorded_in() {
        let mut tape = Tape::<f64>::new();
        let x = tape.leaf(Tensor::full([3], 2.0));
        tape.enter_scope("a");
        let y = tape.square(x);
        tape.enter_scope("b");
        let z = tape.sum(y);
        tape.enter_scope("a");
        let w = tape.scale(z, 2.0);
        tape.close_scope();
        let after = tape.scale(w, 1.0);
        assert_eq!(tape.scope_of(x), None);
        assert_eq!(tape.scope_of(y), Some("a"));
        assert_eq!(tape.scope_of(z), Some("b"));
        assert_eq!(tape.scope_of(w), Some("a"));
        assert_eq!(tape.scope_of(after), None);
        tape.tag(y, "hidden");
        tape.declare_local_loss("b", z);
        assert_eq!(tape.tags(), &[("hidden", y)]);
        assert_eq!(tape.local_losses(), &[("b", z)]);
        tape.backward(after);
        let t = tape.scope_times();
        assert_eq!(
            t.forward_ms.iter().map(|x| x.0).collect::<Vec<_>>(),
            ["a", "b"]
        );
        assert!(t.backward("a") > 0.0 && t.backward("b") > 0.0);
        assert_eq!(t.backward("c"), 0.0);
        tape.clear();
        assert!(tape.tags().is_empty() && tape.scope_times().forward_ms.is_empty());
    }
}
