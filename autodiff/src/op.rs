//! The extension points every op is written against: [`Op`], [`Pointwise`], and the closure
//! custom-VJP. Built-in ops use exactly these public traits, so a user's op is never second class.
//!
//! Conventions:
//! - `forward` receives the input values and an output tensor that is **zeroed** (unless the op
//!   declares [`Op::overwrites_output`]) and already has the shape [`Op::output_shape`] returned. It may store whatever backward needs in `self`
//!   (saved state: a mask, argmax indices, an FFT of an input).
//! - `backward` receives `dy = ∂L/∂output` and **adds** `∂L/∂input_i` into each slot that
//!   [`GradSlots::wants`]; it never overwrites, because several consumers of one value
//!   accumulate into the same gradient.
//! - Shape mismatches are programming errors: panic naming the op and both shapes.

use crate::pool::BufferPool;
use crate::{Float, Shape, Tensor};

/// One differentiable operation: forward into an explicit destination, backward as a VJP.
pub trait Op<T: Float>: 'static {
    /// Short name shown in panics, hook views and registries (e.g. `"conv2d"`).
    fn name(&self) -> &'static str;

    /// The output shape for these inputs. Panic here, naming the op and shapes, on a mismatch.
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape;

    /// Computes the output into `out` (zeroed, of the shape from `output_shape`).
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>);

    /// Adds the vector–Jacobian product `dyᵀ·∂out/∂input_i` into every wanted slot of `dx`.
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>);

    /// `true` when `forward` writes every element of `out`, so the tape may hand it a recycled
    /// buffer with stale contents instead of zero-filling it first. Default `false` (zeroed).
    fn overwrites_output(&self) -> bool {
        false
    }

    /// Indices of inputs that act as *weights* (the matrix of a matmul, the kernel of a conv).
    /// Learning rules such as feedback alignment replace these in the backward pass only.
    fn weight_inputs(&self) -> &'static [usize] {
        &[]
    }
}

/// What a backward pass sees of its node.
pub struct BackwardCx<'a, T> {
    /// Input values, in the order the op was applied to.
    pub inputs: &'a [&'a Tensor<T>],
    /// The op's output value.
    pub output: &'a Tensor<T>,
    /// `∂L/∂output`, same shape as `output`.
    pub dy: &'a Tensor<T>,
}

/// A gradient buffer handed out by [`GradSlots::target`].
pub enum GradTarget<'a, T> {
    /// The first gradient for this input: contents unspecified, overwrite every element.
    Fresh(&'a mut [T]),
    /// A gradient is already there: add into it.
    Accumulate(&'a mut [T]),
}

impl<'a, T: Float> GradTarget<'a, T> {
    /// The buffer and whether to add into it (`true`) or overwrite it (`false`).
    pub fn into_parts(self) -> (&'a mut [T], bool) {
        match self {
            GradTarget::Fresh(g) => (g, false),
            GradTarget::Accumulate(g) => (g, true),
        }
    }

    /// Writes `src` (same length) into a fresh buffer, or adds it into an accumulating one.
    pub fn write(self, src: &[T]) {
        let (g, add) = self.into_parts();
        write_or_add(g, src, add);
    }
}

/// `dst = src`, or `dst += src` when `add`: [`GradTarget::write`] for one chunk of a buffer
/// split with [`GradTarget::into_parts`] (e.g. across rayon tasks).
pub fn write_or_add<T: Float>(dst: &mut [T], src: &[T], add: bool) {
    assert_eq!(dst.len(), src.len(), "write_or_add: lengths");
    if add {
        dst.iter_mut().zip(src).for_each(|(a, &v)| *a += v);
    } else {
        dst.copy_from_slice(src);
    }
}

/// The gradient accumulators of one node's inputs, allocated lazily (zeroed) on first use.
pub struct GradSlots<'a, T: Float> {
    pub(crate) grads: &'a mut [Option<Tensor<T>>],
    pub(crate) input_ids: &'a [u32],
    pub(crate) input_shapes: &'a [Shape],
    pub(crate) wants: u64,
    pub(crate) pool: &'a mut BufferPool<T>,
}

impl<T: Float> GradSlots<'_, T> {
    /// Whether input `i` needs a gradient (skip the work when it does not).
    pub fn wants(&self, i: usize) -> bool {
        i < 64 && self.wants & (1 << i) != 0
    }

    /// Switches input `i` on or off for the rest of this backward call (used by learning rules
    /// that compute different inputs' gradients with different rules).
    pub fn set_wanted(&mut self, i: usize, wanted: bool) {
        assert!(i < 64, "GradSlots: at most 64 inputs per op");
        if wanted {
            self.wants |= 1 << i;
        } else {
            self.wants &= !(1 << i);
        }
    }

    /// Number of inputs.
    pub fn len(&self) -> usize {
        self.input_ids.len()
    }

    /// True for an op with no inputs.
    pub fn is_empty(&self) -> bool {
        self.input_ids.is_empty()
    }

    /// The accumulator of input `i`: add into it. `None` when the input wants no gradient.
    pub fn slot(&mut self, i: usize) -> Option<&mut Tensor<T>> {
        if !self.wants(i) {
            return None;
        }
        let id = self.input_ids[i] as usize;
        let shape = self.input_shapes[i];
        let pool = &mut *self.pool;
        Some(self.grads[id].get_or_insert_with(|| pool.zeros(shape)))
    }

    /// The gradient buffer of input `i` for an op that can write every element in one pass,
    /// or `None` when the input wants no gradient. When no gradient has reached input `i`
    /// yet, the buffer is [`GradTarget::Fresh`]: its contents are unspecified and the op must
    /// overwrite **every** element (this skips zero-filling it and reading the zeros back).
    /// Otherwise it is [`GradTarget::Accumulate`]: add into it, as with [`GradSlots::slot`].
    ///
    /// In this crate's own tests and in debug builds a fresh buffer is filled with NaN, so an
    /// op that leaves an element unwritten fails its gradient check.
    pub fn target(&mut self, i: usize) -> Option<GradTarget<'_, T>> {
        if !self.wants(i) {
            return None;
        }
        let id = self.input_ids[i] as usize;
        let slot = &mut self.grads[id];
        if slot.is_some() {
            return slot.as_mut().map(|t| GradTarget::Accumulate(t.data_mut()));
        }
        let mut fresh = self.pool.uninit(self.input_shapes[i]);
        if cfg!(any(test, debug_assertions)) {
            fresh.data_mut().fill(T::nan());
        }
        Some(GradTarget::Fresh(slot.insert(fresh).data_mut()))
    }

    /// Hands over `g` (same shape as input `i`) as input `i`'s gradient: when no gradient has
    /// reached input `i` yet, `g` becomes it as is (no copy, no zero-fill); otherwise `g` is
    /// added in and its buffer goes back to the tape's pool (as it does when input `i` wants
    /// no gradient). For ops that produce a whole gradient in a tensor of their own.
    #[track_caller]
    pub fn give(&mut self, i: usize, g: Tensor<T>) {
        if !self.wants(i) {
            self.pool.put(g);
            return;
        }
        assert_eq!(
            g.shape(),
            self.input_shapes[i],
            "GradSlots::give: input {i} gradient shape"
        );
        let id = self.input_ids[i] as usize;
        match &mut self.grads[id] {
            Some(acc) => {
                acc.data_mut()
                    .iter_mut()
                    .zip(g.data())
                    .for_each(|(a, &b)| *a += b);
                self.pool.put(g);
            }
            slot @ None => *slot = Some(g),
        }
    }

    /// The accumulator of input `i` as a flat slice: add into it.
    pub fn slot_data(&mut self, i: usize) -> Option<&mut [T]> {
        self.slot(i).map(|t| t.data_mut())
    }

    /// Adds `g` (same shape as input `i`) into its accumulator, if wanted.
    #[track_caller]
    pub fn add(&mut self, i: usize, g: &Tensor<T>) {
        if let Some(s) = self.slot(i) {
            assert_eq!(
                s.shape(),
                g.shape(),
                "GradSlots::add: input {i} gradient shape"
            );
            for (a, &b) in s.data_mut().iter_mut().zip(g.data()) {
                *a += b;
            }
        }
    }

    /// A zeroed scratch tensor from the tape's pool; give it back with [`GradSlots::recycle`].
    pub fn scratch(&mut self, shape: impl Into<Shape>) -> Tensor<T> {
        self.pool.zeros(shape.into())
    }

    /// Returns a scratch tensor to the pool.
    pub fn recycle(&mut self, t: Tensor<T>) {
        self.pool.put(t);
    }
}

/// A pointwise function and its derivative: the dfdx `f`/`df` split.
///
/// `df(x, y)` receives the input `x` and the output `y = f(x)`; return `∂y/∂x` (or, for a
/// surrogate gradient, whatever the backward pass should use instead). Computed in f64.
pub trait Pointwise: 'static {
    /// Name shown in panics and hooks.
    fn name(&self) -> &'static str;
    /// The forward function.
    fn f(&self, x: f64) -> f64;
    /// The derivative used by backward, given input `x` and output `y`.
    fn df(&self, x: f64, y: f64) -> f64;
    /// `false` when `df` is a surrogate, not the derivative of `f` (gradient checks then
    /// compare against `df` instead of finite differences).
    fn exact(&self) -> bool {
        true
    }
}

/// Adapts a [`Pointwise`] into an [`Op`] (what [`crate::Tape::map`] records).
pub struct PointwiseOp<P>(pub P);

impl<T: Float, P: Pointwise> Op<T> for PointwiseOp<P> {
    fn name(&self) -> &'static str {
        self.0.name()
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 1, "{}: takes one input", self.0.name());
        inputs[0].shape()
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        for (o, &x) in out.data_mut().iter_mut().zip(inputs[0].data()) {
            *o = T::of(self.0.f(x.as_f64()));
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if let Some(g) = dx.slot_data(0) {
            let (x, y, dy) = (cx.inputs[0].data(), cx.output.data(), cx.dy.data());
            for i in 0..g.len() {
                g[i] += dy[i] * T::of(self.0.df(x[i].as_f64(), y[i].as_f64()));
            }
        }
    }
}

/// The boxed VJP closure of [`crate::Tape::custom_vjp`].
pub type VjpFn<T> = Box<dyn Fn(&BackwardCx<'_, T>, &mut GradSlots<'_, T>)>;

/// An op whose output was computed by the caller and whose backward is a closure.
pub(crate) struct ClosureOp<T: Float> {
    pub(crate) name: &'static str,
    pub(crate) value: Option<Tensor<T>>,
    pub(crate) vjp: VjpFn<T>,
}

impl<T: Float> Op<T> for ClosureOp<T> {
    fn name(&self) -> &'static str {
        self.name
    }
    fn output_shape(&self, _inputs: &[&Tensor<T>]) -> Shape {
        self.value
            .as_ref()
            .expect("custom_vjp: value already taken")
            .shape()
    }
    fn forward(&mut self, _inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let v = self.value.take().expect("custom_vjp: forward runs once");
        out.data_mut().copy_from_slice(v.data());
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        (self.vjp)(cx, dx)
    }
}
