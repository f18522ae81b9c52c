//! Explicit broadcasting and reshaping. Nothing in the crate broadcasts implicitly.
//!
//! Broadcasting follows NumPy's rules, read from the right: `y` broadcasts to `shape` when
//! `rank(y) ≤ rank(shape)` and each axis of `y` (aligned to the right) is 1 or equal to the
//! target's. Missing leading axes count as 1. A per-channel bias for `(B, C, H, W)` images is
//! therefore `(C, 1, 1)` (or `(1, C, 1, 1)`), not `(C,)`, which would align with `W`.
//!
//! - [`BroadcastTo`] `y → shape` materialises the copy; backward sums `dy` over the expanded axes.
//! - [`AddBroadcast`] `x + y` and [`MulBroadcast`] `x ⊙ y`, with `y` broadcast to `x`'s shape,
//!   read `y` through strides (stride 0 on expanded axes) and never materialise it.
//!   `d(x + y): dx += dy, dy_y += Σ_expanded dy`; `d(x ⊙ y): dx += dy ⊙ y, dy_y += Σ_expanded dy ⊙ x`.
//! - [`Reshape`] keeps the row-major order of elements; backward reshapes `dy` back.
//!
//! Shape errors panic naming the op and both shapes.

use crate::op::{BackwardCx, GradSlots, Op};
use crate::tensor::MAX_RANK;
use crate::{Float, Shape, Tape, Tensor, Var};

/// Names of the ops in this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["broadcast_to", "add_broadcast", "mul_broadcast", "reshape"];

/// How a broadcast operand is read: after dropping length-1 target axes and merging neighbours
/// of the same kind, `k` axes of `lens`, with operand stride `ystride` (0 on expanded axes).
/// The last axis is walked as a contiguous row, so rows are as long as possible.
/// Shared with [`crate::ops::reduce`], where an axis sum is a broadcast read backwards.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plan {
    lens: [usize; MAX_RANK],
    ystride: [usize; MAX_RANK],
    k: usize,
}

impl Plan {
    #[track_caller]
    pub(crate) fn new(op: &str, y: Shape, target: Shape) -> Plan {
        let fail = || -> ! { panic!("{op}: cannot broadcast {y:?} to {target:?}") };
        let r = target.rank();
        if y.rank() > r {
            fail();
        }
        let pad = r - y.rank();
        let (mut lens, mut expanded, mut k) = ([1usize; MAX_RANK], [false; MAX_RANK], 0);
        for a in 0..r {
            let (td, yd) = (target.dim(a), if a < pad { 1 } else { y.dim(a - pad) });
            if yd != td && yd != 1 {
                fail();
            }
            if td == 1 {
                continue;
            }
            let e = yd == 1;
            if k > 0 && expanded[k - 1] == e {
                lens[k - 1] *= td;
            } else {
                lens[k] = td;
                expanded[k] = e;
                k += 1;
            }
        }
        if k == 0 {
            // Everything has length 1: one row of one element.
            return Plan {
                lens,
                ystride: [1; MAX_RANK],
                k: 1,
            };
        }
        let mut ystride = [0usize; MAX_RANK];
        let mut s = 1;
        for a in (0..k).rev() {
            if !expanded[a] {
                ystride[a] = s;
                s *= lens[a];
            }
        }
        Plan { lens, ystride, k }
    }

    /// Length of a row and the operand step along it (0 or 1).
    pub(crate) fn row(&self) -> (usize, usize) {
        (self.lens[self.k - 1], self.ystride[self.k - 1])
    }

    /// Calls `f(out_offset, y_offset)` for every row of the (contiguous) target.
    pub(crate) fn for_each_row(&self, mut f: impl FnMut(usize, usize)) {
        let k = self.k;
        let (n, _) = self.row();
        let outer: usize = self.lens[..k - 1].iter().product();
        let mut idx = [0usize; MAX_RANK];
        let (mut o, mut yo) = (0, 0);
        for _ in 0..outer {
            f(o, yo);
            o += n;
            let mut a = k - 1;
            while a > 0 {
                a -= 1;
                idx[a] += 1;
                yo += self.ystride[a];
                if idx[a] < self.lens[a] {
                    break;
                }
                yo -= self.ystride[a] * self.lens[a];
                idx[a] = 0;
            }
        }
    }

    /// `gy[j] += Σ_{rows, i} w(o + i) · 1` over the positions that read `y[j]`, where
    /// `w(i) = dy[i] · (x[i] if given)`.
    pub(crate) fn reduce_into<T: Float>(&self, gy: &mut [T], dy: &[T], x: Option<&[T]>) {
        let (n, step) = self.row();
        self.for_each_row(|o, yo| {
            let d = &dy[o..o + n];
            match (step, x) {
                (1, None) => gy[yo..yo + n].iter_mut().zip(d).for_each(|(g, &d)| *g += d),
                (1, Some(x)) => {
                    let x = &x[o..o + n];
                    gy[yo..yo + n]
                        .iter_mut()
                        .zip(d)
                        .zip(x)
                        .for_each(|((g, &d), &x)| *g += d * x)
                }
                (_, None) => gy[yo] += d.iter().copied().sum::<T>(),
                (_, Some(x)) => {
                    gy[yo] += d.iter().zip(&x[o..o + n]).map(|(&d, &x)| d * x).sum::<T>()
                }
            }
        });
    }
}

/// `y → shape` by NumPy broadcasting (a materialised copy).
#[derive(Clone, Debug)]
pub struct BroadcastTo {
    shape: Shape,
    plan: Option<Plan>,
}

impl<T: Float> Op<T> for BroadcastTo {
    fn name(&self) -> &'static str {
        "broadcast_to"
    }
    fn output_shape(&self, _inputs: &[&Tensor<T>]) -> Shape {
        self.shape
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let plan = Plan::new("broadcast_to", inputs[0].shape(), self.shape);
        let (n, step) = plan.row();
        let (y, out) = (inputs[0].data(), out.data_mut());
        plan.for_each_row(|o, yo| {
            if step == 1 {
                out[o..o + n].copy_from_slice(&y[yo..yo + n]);
            } else {
                out[o..o + n].fill(y[yo]);
            }
        });
        self.plan = Some(plan);
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if let (Some(g), Some(plan)) = (dx.slot_data(0), self.plan) {
            plan.reduce_into(g, cx.dy.data(), None);
        }
    }
}

macro_rules! broadcast_binary {
    ($(#[$doc:meta])* $name:ident, $str:literal, $mul:expr) => {
        $(#[$doc])*
        #[derive(Clone, Debug, Default)]
        pub struct $name {
            plan: Option<Plan>,
        }

        impl<T: Float> Op<T> for $name {
            fn name(&self) -> &'static str {
                $str
            }
            #[track_caller]
            fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
                assert_eq!(inputs.len(), 2, "{}: takes two inputs (x, y)", $str);
                Plan::new($str, inputs[1].shape(), inputs[0].shape());
                inputs[0].shape()
            }
            fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
                let plan = Plan::new($str, inputs[1].shape(), inputs[0].shape());
                let (n, step) = plan.row();
                let (x, y, out) = (inputs[0].data(), inputs[1].data(), out.data_mut());
                plan.for_each_row(|o, yo| {
                    let (out, x) = (&mut out[o..o + n], &x[o..o + n]);
                    for i in 0..n {
                        let yv = y[yo + i * step];
                        out[i] = if $mul { x[i] * yv } else { x[i] + yv };
                    }
                });
                self.plan = Some(plan);
            }
            fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
                let plan = self.plan.expect(concat!($str, ": backward before forward"));
                let (dy, y) = (cx.dy.data(), cx.inputs[1].data());
                if let Some(gx) = dx.slot_data(0) {
                    if $mul {
                        let (n, step) = plan.row();
                        plan.for_each_row(|o, yo| {
                            for i in 0..n {
                                gx[o + i] += dy[o + i] * y[yo + i * step];
                            }
                        });
                    } else {
                        gx.iter_mut().zip(dy).for_each(|(g, &d)| *g += d);
                    }
                }
                if let Some(gy) = dx.slot_data(1) {
                    plan.reduce_into(gy, dy, if $mul { Some(cx.inputs[0].data()) } else { None });
                }
            }
        }
    };
}

broadcast_binary!(
    /// `x + y` with `y` broadcast to `x`'s shape (not materialised).
    AddBroadcast,
    "add_broadcast",
    false
);
broadcast_binary!(
    /// `x ⊙ y` with `y` broadcast to `x`'s shape (not materialised).
    MulBroadcast,
    "mul_broadcast",
    true
);

/// The same elements in a new shape with the same number of elements (row-major order).
#[derive(Clone, Debug)]
pub struct Reshape {
    shape: Shape,
}

impl<T: Float> Op<T> for Reshape {
    fn name(&self) -> &'static str {
        "reshape"
    }
    #[track_caller]
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let from = inputs[0].shape();
        assert_eq!(
            from.numel(),
            self.shape.numel(),
            "reshape: {from:?} cannot become {:?}",
            self.shape
        );
        self.shape
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        out.data_mut().copy_from_slice(inputs[0].data());
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if let Some(g) = dx.slot_data(0) {
            g.iter_mut().zip(cx.dy.data()).for_each(|(g, &d)| *g += d);
        }
    }
}

impl<T: Float> Tape<T> {
    /// Broadcasts `x` to `shape` (NumPy rules, see the module docs).
    #[track_caller]
    pub fn broadcast_to(&mut self, x: Var, shape: impl Into<Shape>) -> Var {
        let shape = shape.into();
        Plan::new("broadcast_to", self.shape(x), shape);
        self.apply(BroadcastTo { shape, plan: None }, &[x])
    }

    /// `x + y`, `y` broadcast to `x`'s shape (e.g. a bias `(C, 1, 1)` onto `(B, C, H, W)`).
    #[track_caller]
    pub fn add_broadcast(&mut self, x: Var, y: Var) -> Var {
        self.apply(AddBroadcast::default(), &[x, y])
    }

    /// `x ⊙ y`, `y` broadcast to `x`'s shape (e.g. a per-channel gain).
    #[track_caller]
    pub fn mul_broadcast(&mut self, x: Var, y: Var) -> Var {
        self.apply(MulBroadcast::default(), &[x, y])
    }

    /// The elements of `x` in `shape` (same count, row-major order).
    #[track_caller]
    pub fn reshape(&mut self, x: Var, shape: impl Into<Shape>) -> Var {
        self.apply(
            Reshape {
                shape: shape.into(),
            },
            &[x],
        )
    }
}

#[cfg(test)]
mod tests;
