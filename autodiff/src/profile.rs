//! Per-op wall-clock profile of a tape: how long each op family spends in forward and backward.
//!
//! Opt-in and cheap: [`Tape::set_profiling`](crate::Tape::set_profiling)`(true)` makes [`Tape::apply`](crate::Tape::apply) and the reverse loop
//! read the clock around each op (two `Instant::now()` per op and direction, ≈ 50 ns); when off,
//! nothing is timed. Times accumulate across steps and across `clear()` until
//! [`Tape::take_profile`](crate::Tape::take_profile) hands them over and starts afresh, so one profile can cover many
//! training steps.
//!
//! Rows are keyed by [`Op::name`](crate::Op::name) (all conv2d calls share one row), in the order
//! each name was first seen. Backward time includes what a [`BackwardHooks`](crate::BackwardHooks)
//! override does in place of the op; gradient-slot allocation is counted with the op that asked
//! for it. Times are wall clock in seconds (ops run in parallel inside, so they do not add up to
//! CPU time).
//!
//! ```
//! use autodiff::{Tape, Tensor};
//! let mut tape = Tape::<f32>::new();
//! tape.set_profiling(true);
//! let x = tape.leaf(Tensor::full([4, 4], 2.0));
//! let y = tape.mul(x, x);
//! let l = tape.sum(y);
//! tape.backward(l);
//! let profile = tape.take_profile();
//! assert_eq!(profile.row("mul").unwrap().calls, 1);
//! println!("{profile}");
//! ```

use std::fmt;

/// The time one op family took (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct OpTime {
    /// [`Op::name`](crate::Op::name).
    pub name: &'static str,
    /// Forward calls recorded.
    pub calls: usize,
    /// Total forward wall time, s.
    pub forward_s: f64,
    /// Backward calls made.
    pub backward_calls: usize,
    /// Total backward wall time, s.
    pub backward_s: f64,
}

/// Per-op times accumulated by a profiling tape.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Profile {
    rows: Vec<OpTime>,
}

impl Profile {
    fn entry(&mut self, name: &'static str) -> &mut OpTime {
        // Few distinct names (tens): a linear scan beats hashing here.
        let i = match self.rows.iter().position(|r| r.name == name) {
            Some(i) => i,
            None => {
                self.rows.push(OpTime {
                    name,
                    calls: 0,
                    forward_s: 0.0,
                    backward_calls: 0,
                    backward_s: 0.0,
                });
                self.rows.len() - 1
            }
        };
        &mut self.rows[i]
    }

    pub(crate) fn add_forward(&mut self, name: &'static str, seconds: f64) {
        let r = self.entry(name);
        r.calls += 1;
        r.forward_s += seconds;
    }

    pub(crate) fn add_backward(&mut self, name: &'static str, seconds: f64) {
        let r = self.entry(name);
        r.backward_calls += 1;
        r.backward_s += seconds;
    }

    /// All rows, in order of first appearance.
    pub fn rows(&self) -> &[OpTime] {
        &self.rows
    }

    /// The row of op `name`, if it ran.
    pub fn row(&self, name: &str) -> Option<&OpTime> {
        self.rows.iter().find(|r| r.name == name)
    }

    /// Every time (not the call counts) multiplied by `factor`, e.g. `1 / steps` for times per
    /// step.
    pub fn scaled(&self, factor: f64) -> Profile {
        let mut p = self.clone();
        for r in &mut p.rows {
            r.forward_s *= factor;
            r.backward_s *= factor;
        }
        p
    }

    /// Forward + backward seconds over all rows.
    pub fn total_s(&self) -> f64 {
        self.rows.iter().map(|r| r.forward_s + r.backward_s).sum()
    }
}

impl fmt::Display for Profile {
    /// A table sorted by forward + backward time, slowest first, in milliseconds.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut rows: Vec<&OpTime> = self.rows.iter().collect();
        rows.sort_by(|a, b| (b.forward_s + b.backward_s).total_cmp(&(a.forward_s + a.backward_s)));
        writeln!(
            f,
            "{:<28} {:>7} {:>11} {:>11} {:>11}",
            "op", "calls", "forward ms", "backward ms", "total ms"
        )?;
        for r in rows {
            writeln!(
                f,
                "{:<28} {:>7} {:>11.3} {:>11.3} {:>11.3}",
                r.name,
                r.calls,
                r.forward_s * 1e3,
                r.backward_s * 1e3,
                (r.forward_s + r.backward_s) * 1e3
            )?;
        }
        write!(f, "{:<28} {:>7} {:>35.3}", "all", "", self.total_s() * 1e3)
    }
}

#[cfg(test)]
mod tests {
    use crate::{Tape, Tensor};

    #[test]
    fn profile_counts_calls_per_op_and_is_off_by_default() {
        let mut tape = Tape::<f32>::new();
        for profiling in [false, true] {
            tape.set_profiling(profiling);
            for _ in 0..3 {
                tape.clear();
                let x = tape.leaf(Tensor::full([8, 8], 1.5));
                let y = tape.mul(x, x);
                let z = tape.mul(y, x);
                let l = tape.sum(z);
                tape.backward(l);
            }
            let p = tape.take_profile();
            if !profiling {
                assert!(p.rows().is_empty(), "profiled while off: {p:?}");
                continue;
            }
            let mul = p.row("mul").expect("mul row");
            assert_eq!((mul.calls, mul.backward_calls), (6, 6));
            assert_eq!(p.row("sum").map(|r| r.calls), Some(3));
            assert!(mul.forward_s > 0.0 && mul.backward_s > 0.0);
            assert!(p.total_s() >= mul.forward_s + mul.backward_s);
            // Taking the profile starts a new one.
            assert!(tape.take_profile().rows().is_empty());
        }
    }
}
