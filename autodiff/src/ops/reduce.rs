//! Reductions: sum and mean over everything or over chosen axes, max and min over everything.
//!
//! - [`Sum`] / [`Mean`]: all elements → a rank-0 scalar. `∂/∂x_i = 1` (or `1/n`). Sums are
//!   accumulated in f64, also on an f32 tape, so a loss over a large image is not dominated by
//!   round-off; large tensors are summed in parallel over chunks of fixed size, so the result
//!   does not depend on the number of threads.
//! - [`SumAxes`] / [`MeanAxes`]: sum (mean) over a set of axes. With `keepdim` the reduced axes
//!   stay with length 1 (`(B, C, H, W)` over `[2, 3]` → `(B, C, 1, 1)`), otherwise they are
//!   removed (→ `(B, C)`). Backward broadcasts `dy` back over the reduced axes.
//! - [`Max`] / [`Min`]: the largest (smallest) element → a scalar; the gradient goes to the first
//!   position attaining it (a subgradient at ties).
//!
//! An axis out of range panics naming the op and the shape.

use crate::op::{BackwardCx, GradSlots, GradTarget, Op};
use crate::ops::broadcast::Plan;
use crate::tensor::MAX_RANK;
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// Names of the ops in this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["sum", "mean", "sum_axes", "mean_axes", "max", "min"];

/// `Σ v` in `T`, with 8 independent partial sums so the loop vectorises (the per-plane sums
/// of bias gradients).
pub(crate) fn lane_sum<T: Float>(v: &[T]) -> T {
    let mut acc = [T::zero(); 8];
    let chunks = v.chunks_exact(8);
    let tail = chunks.remainder().iter().fold(T::zero(), |s, &x| s + x);
    for c in chunks {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a += x;
        }
    }
    acc.iter().fold(tail, |s, &x| s + x)
}

/// Elements per parallel task of the whole-tensor sums here and in [`crate::ops::loss`], and
/// of their backward fills: a fixed size, so that a sum's rounding does not depend on the
/// thread count.
pub(crate) const TASK_ELEMS: usize = 1 << 16;

/// `Σ_{i < n} term(i)` in f64 with 8 independent partial sums (term `i` into sum `i mod 8`,
/// then the 8 in order), so that the additions do not wait for each other as one running sum
/// does.
pub(crate) fn lanes_total(n: usize, term: impl Fn(usize) -> f64) -> f64 {
    let mut acc = [0.0f64; 8];
    let full = n - n % 8;
    for i in (0..full).step_by(8) {
        for (l, a) in acc.iter_mut().enumerate() {
            *a += term(i + l);
        }
    }
    let tail: f64 = (full..n).map(&term).sum();
    acc.iter().sum::<f64>() + tail
}

/// `Σ part(range)` over the [`TASK_ELEMS`] chunks of `0..n`, chunks in parallel, their sums
/// added in order (one call for `n ≤ TASK_ELEMS`).
pub(crate) fn chunked_total(n: usize, part: impl Fn(std::ops::Range<usize>) -> f64 + Sync) -> f64 {
    if n <= TASK_ELEMS {
        return part(0..n);
    }
    let parts: Vec<f64> = (0..n.div_ceil(TASK_ELEMS))
        .into_par_iter()
        .map(|k| part(k * TASK_ELEMS..((k + 1) * TASK_ELEMS).min(n)))
        .collect();
    parts.iter().sum()
}

/// Sum of all elements, in f64 ([`chunked_total`] of [`lanes_total`]).
fn total<T: Float>(x: &[T]) -> f64 {
    chunked_total(x.len(), |r| {
        let x = &x[r];
        lanes_total(x.len(), |i| x[i].as_f64())
    })
}

/// `g = d` (`add == false`) or `g += d` for every element, in parallel for large tensors.
fn fill_or_add<T: Float>(g: &mut [T], d: T, add: bool) {
    let run = |g: &mut [T]| match add {
        true => g.iter_mut().for_each(|g| *g += d),
        false => g.fill(d),
    };
    if g.len() <= TASK_ELEMS {
        run(g);
    } else {
        g.par_chunks_mut(TASK_ELEMS).for_each(run);
    }
}

macro_rules! reduce_all {
    ($(#[$doc:meta])* $name:ident, $str:literal, $mean:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default)]
        pub struct $name;
        impl<T: Float> Op<T> for $name {
            fn name(&self) -> &'static str {
                $str
            }
            fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
                assert_eq!(inputs.len(), 1, "{}: takes one input", $str);
                Shape::scalar()
            }
            fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
                let x = inputs[0].data();
                let s = total(x);
                out.data_mut()[0] = T::of(if $mean { s / x.len().max(1) as f64 } else { s });
            }
            fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
                let n = cx.inputs[0].numel().max(1);
                let d = if $mean { cx.dy.data()[0] / T::of(n as f64) } else { cx.dy.data()[0] };
                if let Some((g, add)) = dx.target(0).map(GradTarget::into_parts) {
                    fill_or_add(g, d, add);
                }
            }
        }
    };
}

reduce_all!(
    /// `y = Σ x` (rank-0 output).
    Sum,
    "sum",
    false
);
reduce_all!(
    /// `y = Σ x / n` (rank-0 output).
    Mean,
    "mean",
    true
);

/// The input shape with the axes in `mask` set to 1 (`keepdim` form), and the output shape.
fn reduced_shapes(x: Shape, mask: u8, keepdim: bool) -> (Shape, Shape) {
    let (mut keep, mut kept, mut k) = ([1usize; MAX_RANK], [0usize; MAX_RANK], 0);
    for (a, &d) in x.dims().iter().enumerate() {
        if mask & (1 << a) == 0 {
            keep[a] = d;
            kept[k] = d;
            k += 1;
        }
    }
    let keep = Shape::new(&keep[..x.rank()]);
    (
        keep,
        if keepdim {
            keep
        } else {
            Shape::new(&kept[..k])
        },
    )
}

#[track_caller]
fn axes_mask(op: &str, x: Shape, axes: &[usize]) -> u8 {
    let mut m = 0u8;
    for &a in axes {
        assert!(a < x.rank(), "{op}: axis {a} out of range for {x:?}");
        m |= 1 << a;
    }
    m
}

macro_rules! reduce_axes {
    ($(#[$doc:meta])* $name:ident, $str:literal, $mean:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug)]
        pub struct $name {
            mask: u8,
            keepdim: bool,
            plan: Option<(Plan, usize)>,
        }
        impl<T: Float> Op<T> for $name {
            fn name(&self) -> &'static str {
                $str
            }
            fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
                reduced_shapes(inputs[0].shape(), self.mask, self.keepdim).1
            }
            fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
                let x = inputs[0].shape();
                let keep = reduced_shapes(x, self.mask, self.keepdim).0;
                let plan = Plan::new($str, keep, x);
                let count = x.numel() / keep.numel().max(1);
                plan.reduce_into(out.data_mut(), inputs[0].data(), None);
                if $mean {
                    let s = T::of(1.0 / count.max(1) as f64);
                    out.data_mut().iter_mut().for_each(|v| *v *= s);
                }
                self.plan = Some((plan, count));
            }
            fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
                let (plan, count) = self.plan.expect(concat!($str, ": backward before forward"));
                if let Some(g) = dx.slot_data(0) {
                    let s = if $mean { T::of(1.0 / count.max(1) as f64) } else { T::one() };
                    let (n, step) = plan.row();
                    let dy = cx.dy.data();
                    plan.for_each_row(|o, yo| {
                        for i in 0..n {
                            g[o + i] += s * dy[yo + i * step];
                        }
                    });
                }
            }
        }
    };
}

reduce_axes!(
    /// `y = Σ_axes x`, keeping the reduced axes as length 1 when `keepdim`.
    SumAxes,
    "sum_axes",
    false
);
reduce_axes!(
    /// `y = mean_axes x`, keeping the reduced axes as length 1 when `keepdim`.
    MeanAxes,
    "mean_axes",
    true
);

macro_rules! extremum {
    ($(#[$doc:meta])* $name:ident, $str:literal, $better:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default)]
        pub struct $name {
            at: usize,
        }
        impl<T: Float> Op<T> for $name {
            fn name(&self) -> &'static str {
                $str
            }
            #[track_caller]
            fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
                assert!(inputs[0].numel() > 0, "{}: empty input {:?}", $str, inputs[0].shape());
                Shape::scalar()
            }
            fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
                let x = inputs[0].data();
                let better: fn(T, T) -> bool = $better;
                self.at = (1..x.len()).fold(0, |best, i| if better(x[i], x[best]) { i } else { best });
                out.data_mut()[0] = x[self.at];
            }
            fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
                if let Some(g) = dx.slot_data(0) {
                    g[self.at] += cx.dy.data()[0];
                }
            }
        }
    };
}

extremum!(
    /// `y = max x`; the gradient goes to the first maximal element.
    Max,
    "max",
    |a, b| a > b
);
extremum!(
    /// `y = min x`; the gradient goes to the first minimal element.
    Min,
    "min",
    |a, b| a < b
);

impl<T: Float> Tape<T> {
    /// `Σ x` over all elements (rank-0 result).
    pub fn sum(&mut self, x: Var) -> Var {
        self.apply(Sum, &[x])
    }
    /// Mean over all elements (rank-0 result).
    pub fn mean(&mut self, x: Var) -> Var {
        self.apply(Mean, &[x])
    }
    /// Sum over `axes`; reduced axes stay as length 1 when `keepdim`, else they are removed.
    #[track_caller]
    pub fn sum_axes(&mut self, x: Var, axes: &[usize], keepdim: bool) -> Var {
        let mask = axes_mask("sum_axes", self.shape(x), axes);
        self.apply(
            SumAxes {
                mask,
                keepdim,
                plan: None,
            },
            &[x],
        )
    }
    /// Mean over `axes`; reduced axes stay as length 1 when `keepdim`, else they are removed.
    #[track_caller]
    pub fn mean_axes(&mut self, x: Var, axes: &[usize], keepdim: bool) -> Var {
        let mask = axes_mask("mean_axes", self.shape(x), axes);
        self.apply(
            MeanAxes {
                mask,
                keepdim,
                plan: None,
            },
            &[x],
        )
    }
    /// The largest element (rank-0 result).
    #[track_caller]
    pub fn max(&mut self, x: Var) -> Var {
        self.apply(Max::default(), &[x])
    }
    /// The smallest element (rank-0 result).
    #[track_caller]
    pub fn min(&mut self, x: Var) -> Var {
        self.apply(Min::default(), &[x])
    }
}

#[cfg(test)]
pub(crate) mod tests;
