//! Element-wise arithmetic and activations.
//!
//! - **Binary** ops ([`Add`], [`Sub`], [`Mul`], [`Div`]) take two tensors of the *same* shape
//!   (no implicit broadcasting: see [`crate::ops::broadcast`]); a mismatch panics naming the op
//!   and both shapes. Derivatives: `d(a+b) = da + db`, `d(a−b) = da − db`,
//!   `d(a·b) = b·da + a·db`, `d(a/b) = da/b − (a/b²)·db`.
//! - **Unary** ops are [`Pointwise`] structs ([`Exp`], [`Sigmoid`], [`Pow`], …), so the same
//!   `f`/`df` pair serves the tape ([`Tape::map`]) and the gradient check. `f` and `df` run in
//!   f64, also on an f32 tape. Each struct documents its `f` and `df`.
//! - [`Relu`] is a dedicated [`Op`] (it sits in the U-Net hot path): no conversion to f64, no
//!   allocation beyond the pooled output, rayon over chunks for large tensors. Its derivative at
//!   0 is taken as 0 (`dy · [y > 0]`).
//! - Domains are the caller's business: `log` and `sqrt` of non-positive values, or `Pow` with a
//!   non-integer exponent of negative values, give NaN like `f64` does.

use crate::op::{BackwardCx, GradSlots, Op, Pointwise};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// Names of the ops in this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &[
    "add",
    "sub",
    "mul",
    "div",
    "relu",
    "neg",
    "scale",
    "add_scalar",
    "square",
    "sqrt",
    "exp",
    "log",
    "abs",
    "sigmoid",
    "tanh",
    "softplus",
    "pow",
];

/// Tensors at least this long are processed in parallel chunks.
const PAR_MIN_LEN: usize = 1 << 16;
const PAR_CHUNK: usize = 1 << 14;

/// `out[i] = f(out[i], a[i], b[i])`, in parallel chunks when large.
fn zip3<T: Float>(out: &mut [T], a: &[T], b: &[T], f: impl Fn(&mut T, T, T) + Sync) {
    if out.len() >= PAR_MIN_LEN {
        out.par_chunks_mut(PAR_CHUNK)
            .zip(a.par_chunks(PAR_CHUNK))
            .zip(b.par_chunks(PAR_CHUNK))
            .for_each(|((o, a), b)| {
                o.iter_mut()
                    .zip(a)
                    .zip(b)
                    .for_each(|((o, &a), &b)| f(o, a, b))
            });
    } else {
        out.iter_mut()
            .zip(a)
            .zip(b)
            .for_each(|((o, &a), &b)| f(o, a, b));
    }
}

#[track_caller]
fn same_shape<T: Float>(op: &str, inputs: &[&Tensor<T>]) -> Shape {
    assert_eq!(
        inputs.len(),
        2,
        "{op}: takes two inputs, got {}",
        inputs.len()
    );
    let (a, b) = (inputs[0].shape(), inputs[1].shape());
    assert!(
        a == b,
        "{op}: shapes differ, lhs {a:?} vs rhs {b:?} (use add_broadcast/mul_broadcast)"
    );
    a
}

macro_rules! binary_op {
    ($(#[$doc:meta])* $name:ident, $str:literal, |$o:ident, $a:ident, $b:ident| $fwd:expr,
     |$cx:ident, $dx:ident| $bwd:block) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default)]
        pub struct $name;
        impl<T: Float> Op<T> for $name {
            fn name(&self) -> &'static str {
                $str
            }
            fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
                same_shape($str, inputs)
            }
            fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
                zip3(out.data_mut(), inputs[0].data(), inputs[1].data(), |$o, $a, $b| *$o = $fwd);
            }
            fn backward(&self, $cx: &BackwardCx<'_, T>, $dx: &mut GradSlots<'_, T>) $bwd
        }
    };
}

binary_op!(
    /// `y = a + b`; `da += dy`, `db += dy`.
    Add, "add", |o, a, b| a + b,
    |cx, dx| {
        for i in 0..2 {
            if let Some(g) = dx.slot_data(i) {
                zip3(g, cx.dy.data(), cx.dy.data(), |g, d, _| *g += d);
            }
        }
    }
);

binary_op!(
    /// `y = a − b`; `da += dy`, `db −= dy`.
    Sub, "sub", |o, a, b| a - b,
    |cx, dx| {
        if let Some(g) = dx.slot_data(0) {
            zip3(g, cx.dy.data(), cx.dy.data(), |g, d, _| *g += d);
        }
        if let Some(g) = dx.slot_data(1) {
            zip3(g, cx.dy.data(), cx.dy.data(), |g, d, _| *g -= d);
        }
    }
);

binary_op!(
    /// `y = a ⊙ b`; `da += dy ⊙ b`, `db += dy ⊙ a`.
    Mul, "mul", |o, a, b| a * b,
    |cx, dx| {
        for i in 0..2 {
            if let Some(g) = dx.slot_data(i) {
                zip3(g, cx.dy.data(), cx.inputs[1 - i].data(), |g, d, other| *g += d * other);
            }
        }
    }
);

binary_op!(
    /// `y = a / b`; `da += dy / b`, `db −= dy ⊙ y / b`.
    Div, "div", |o, a, b| a / b,
    |cx, dx| {
        let b = cx.inputs[1].data();
        if let Some(g) = dx.slot_data(0) {
            zip3(g, cx.dy.data(), b, |g, d, b| *g += d / b);
        }
        if let Some(g) = dx.slot_data(1) {
            let y = cx.output.data();
            for i in 0..g.len() {
                g[i] -= cx.dy.data()[i] * y[i] / b[i];
            }
        }
    }
);

/// `y = max(x, 0)`; `dx += dy · [y > 0]` (derivative 0 at the kink).
#[derive(Clone, Copy, Debug, Default)]
pub struct Relu;

impl<T: Float> Op<T> for Relu {
    fn name(&self) -> &'static str {
        "relu"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(
            inputs.len(),
            1,
            "relu: takes one input, got {}",
            inputs.len()
        );
        inputs[0].shape()
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let x = inputs[0].data();
        zip3(out.data_mut(), x, x, |o, x, _| {
            *o = if x > T::zero() { x } else { T::zero() }
        });
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if let Some(g) = dx.slot_data(0) {
            zip3(g, cx.dy.data(), cx.output.data(), |g, d, y| {
                *g += if y > T::zero() { d } else { T::zero() }
            });
        }
    }
}

macro_rules! pointwise {
    ($(#[$doc:meta])* $name:ident $(($($field:tt)*))?, $str:literal,
     |$s:ident, $x:ident| $f:expr, |$s2:ident, $x2:ident, $y:ident| $df:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug)]
        pub struct $name $(($($field)*))?;
        impl Pointwise for $name {
            fn name(&self) -> &'static str {
                $str
            }
            #[inline]
            fn f(&self, $x: f64) -> f64 {
                let $s = self;
                let _ = $s;
                $f
            }
            #[inline]
            fn df(&self, $x2: f64, $y: f64) -> f64 {
                let $s2 = self;
                let _ = ($s2, $x2, $y);
                $df
            }
        }
    };
}

pointwise!(/// `y = −x`; `dy/dx = −1`.
    Neg, "neg", |s, x| -x, |s, x, y| -1.0);
pointwise!(/// `y = c·x`; `dy/dx = c`.
    Scale(pub f64), "scale", |s, x| s.0 * x, |s, x, y| s.0);
pointwise!(/// `y = x + c`; `dy/dx = 1`.
    AddScalar(pub f64), "add_scalar", |s, x| x + s.0, |s, x, y| 1.0);
pointwise!(/// `y = x²`; `dy/dx = 2x`.
    Square, "square", |s, x| x * x, |s, x, y| 2.0 * x);
pointwise!(/// `y = √x` (x ≥ 0); `dy/dx = 1 / (2y)`.
    Sqrt, "sqrt", |s, x| x.sqrt(), |s, x, y| 0.5 / y);
pointwise!(/// `y = eˣ`; `dy/dx = y`.
    Exp, "exp", |s, x| x.exp(), |s, x, y| y);
pointwise!(/// `y = ln x` (x > 0); `dy/dx = 1/x`.
    Log, "log", |s, x| x.ln(), |s, x, y| 1.0 / x);
pointwise!(/// `y = |x|`; `dy/dx = sign(x)` (0 at the kink).
    Abs, "abs", |s, x| x.abs(), |s, x, y| if x > 0.0 { 1.0 } else if x < 0.0 { -1.0 } else { 0.0 });
pointwise!(/// `y = 1 / (1 + e⁻ˣ)` (overflow-free form); `dy/dx = y(1 − y)`.
    Sigmoid, "sigmoid", |s, x| sigmoid(x), |s, x, y| y * (1.0 - y));
pointwise!(/// `y = tanh x`; `dy/dx = 1 − y²`.
    Tanh, "tanh", |s, x| x.tanh(), |s, x, y| 1.0 - y * y);
pointwise!(/// `y = ln(1 + eˣ)`, computed as `max(x, 0) + ln(1 + e^−|x|)`; `dy/dx = sigmoid(x)`.
    Softplus, "softplus", |s, x| x.max(0.0) + (-x.abs()).exp().ln_1p(), |s, x, y| sigmoid(x));
pointwise!(/// `y = xᵖ` for a constant `p` (x > 0 unless p is an integer); `dy/dx = p·xᵖ⁻¹`.
    Pow(pub f64), "pow", |s, x| x.powf(s.0), |s, x, y| s.0 * x.powf(s.0 - 1.0));

/// The logistic function without overflow for large `|x|`.
fn sigmoid(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

impl<T: Float> Tape<T> {
    /// `a + b` (same shapes).
    #[track_caller]
    pub fn add(&mut self, a: Var, b: Var) -> Var {
        self.apply(Add, &[a, b])
    }
    /// `a − b` (same shapes).
    #[track_caller]
    pub fn sub(&mut self, a: Var, b: Var) -> Var {
        self.apply(Sub, &[a, b])
    }
    /// `a ⊙ b` (same shapes).
    #[track_caller]
    pub fn mul(&mut self, a: Var, b: Var) -> Var {
        self.apply(Mul, &[a, b])
    }
    /// `a / b` (same shapes).
    #[track_caller]
    pub fn div(&mut self, a: Var, b: Var) -> Var {
        self.apply(Div, &[a, b])
    }
    /// `max(x, 0)`.
    pub fn relu(&mut self, x: Var) -> Var {
        self.apply(Relu, &[x])
    }
    /// `−x`.
    pub fn neg(&mut self, x: Var) -> Var {
        self.map(Neg, x)
    }
    /// `c · x`.
    pub fn scale(&mut self, x: Var, c: f64) -> Var {
        self.map(Scale(c), x)
    }
    /// `x + c`.
    pub fn add_scalar(&mut self, x: Var, c: f64) -> Var {
        self.map(AddScalar(c), x)
    }
    /// `x²`.
    pub fn square(&mut self, x: Var) -> Var {
        self.map(Square, x)
    }
    /// `√x`.
    pub fn sqrt(&mut self, x: Var) -> Var {
        self.map(Sqrt, x)
    }
    /// `eˣ`.
    pub fn exp(&mut self, x: Var) -> Var {
        self.map(Exp, x)
    }
    /// `ln x`.
    pub fn log(&mut self, x: Var) -> Var {
        self.map(Log, x)
    }
    /// `|x|`.
    pub fn abs(&mut self, x: Var) -> Var {
        self.map(Abs, x)
    }
    /// `1 / (1 + e⁻ˣ)`.
    pub fn sigmoid(&mut self, x: Var) -> Var {
        self.map(Sigmoid, x)
    }
    /// `tanh x`.
    pub fn tanh(&mut self, x: Var) -> Var {
        self.map(Tanh, x)
    }
    /// `ln(1 + eˣ)`.
    pub fn softplus(&mut self, x: Var) -> Var {
        self.map(Softplus, x)
    }
    /// `xᵖ` for a constant exponent `p`.
    pub fn pow(&mut self, x: Var, p: f64) -> Var {
        self.map(Pow(p), x)
    }
}

#[cfg(test)]
mod tests;
