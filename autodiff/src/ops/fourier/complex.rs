//! Complex pointwise ops on interleaved `(re, im)` tensors, and the moves between the real and
//! complex domains.
//!
//! - `to_complex`: real `(…)` → complex `(…, 2)` with zero imaginary part; `real_part` back.
//! - `complex_mul(a, b)`: `y = a·b`. `b`'s shape must be a suffix of `a`'s (it is broadcast over
//!   `a`'s leading axes): the learned frequency response `(H, W, 2)` times a batch `(B, H, W, 2)`.
//! - `complex_div_guarded(a, b, eps)`: `y = a·conj(b) / (|b|² + eps)`, the regularised inverse
//!   filter of docs/references.md#guarded-w-inverse (eps = 1e-6). It equals `a / b` when
//!   `|b|² ≫ eps` and goes smoothly to 0 as `b → 0`, so it is differentiable everywhere.
//!
//! Derivatives (gradients stored as `(∂L/∂re, ∂L/∂im)`, see [`super`]):
//! - holomorphic `y = f(z)`: `g_z = conj(f′(z))·g_y`, so for the product `g_a = conj(b)·g_y`,
//!   `g_b = Σ_batch conj(a)·g_y`;
//! - the guarded divide is not holomorphic in `b`. With `D = |b|² + eps`,
//!   `∂y/∂b = −a·conj(b)²/D²` and `∂y/∂conj(b) = a·eps/D²`, giving
//!   `g_a = b·g_y/D` and `g_b = Σ_batch [−conj(a)·b²·g_y + a·conj(g_y)·eps] / D²`.

use super::{as_complex, as_complex_mut};
use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};
use rayon::prelude::*;
use rustfft::num_complex::Complex;

/// Complex elements per parallel task.
const CHUNK: usize = 1 << 13;

/// Runs `f(first_element_index, chunk)` over `out` in chunks, in parallel when large.
fn for_chunks<T: Float>(out: &mut [Complex<T>], f: impl Fn(usize, &mut [Complex<T>]) + Sync) {
    if out.len() > CHUNK {
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(i, c)| f(i * CHUNK, c));
    } else {
        f(0, out);
    }
}

/// Splits the flat range `start..start + len` of `a` at multiples of `m` (the length of the
/// broadcast `b`) and calls `f(i, j, n)` for each piece: `a[i..i + n]` pairs with `b[j..j + n]`.
#[inline(always)]
fn pieces(start: usize, len: usize, m: usize, mut f: impl FnMut(usize, usize, usize)) {
    let (mut i, end) = (start, start + len);
    while i < end {
        let j = i % m;
        let n = (m - j).min(end - i);
        f(i, j, n);
        i += n;
    }
}

/// Number of complex elements of `b` when its shape is a complex suffix of `a`'s; panics naming
/// `op` and both shapes otherwise.
#[track_caller]
fn broadcast_len(op: &str, a: Shape, b: Shape) -> usize {
    let (da, db) = (a.dims(), b.dims());
    assert!(
        da.len() >= 3 && da[da.len() - 1] == 2,
        "{op}: expected a complex tensor (…, H, W, 2) as first input, got {a:?}"
    );
    assert!(
        !db.is_empty() && db.len() <= da.len() && da.ends_with(db),
        "{op}: the second input {b:?} must be a complex suffix of the first {a:?} (broadcast over its leading axes)"
    );
    b.numel() / 2
}

struct ToComplex;

impl<T: Float> Op<T> for ToComplex {
    fn name(&self) -> &'static str {
        "to_complex"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let d = inputs[0].dims();
        let mut out = d.to_vec();
        out.push(2);
        assert!(
            out.len() <= crate::tensor::MAX_RANK,
            "to_complex: input {:?} has no room for a complex axis",
            inputs[0].shape()
        );
        Shape::new(&out)
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        for (o, &x) in as_complex_mut(out.data_mut())
            .iter_mut()
            .zip(inputs[0].data())
        {
            o.re = x;
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if let Some(g) = dx.slot_data(0) {
            for (g, dy) in g.iter_mut().zip(as_complex(cx.dy.data())) {
                *g += dy.re;
            }
        }
    }
}

struct RealPart;

impl<T: Float> Op<T> for RealPart {
    fn name(&self) -> &'static str {
        "real_part"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let d = inputs[0].dims();
        assert!(
            !d.is_empty() && d[d.len() - 1] == 2,
            "real_part: expected a complex tensor (…, 2), got {:?}",
            inputs[0].shape()
        );
        Shape::new(&d[..d.len() - 1])
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        for (o, x) in out.data_mut().iter_mut().zip(as_complex(inputs[0].data())) {
            *o = x.re;
        }
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        if let Some(g) = dx.slot_data(0) {
            for (g, &dy) in as_complex_mut(g).iter_mut().zip(cx.dy.data()) {
                g.re += dy;
            }
        }
    }
}

/// `a·b` (`eps = None`) or `a·conj(b)/(|b|² + eps)` (`eps = Some`), `b` broadcast over `a`.
struct ComplexBinary<T> {
    eps: Option<T>,
}

impl<T: Float> ComplexBinary<T> {
    /// `y` for one pair.
    #[inline(always)]
    fn apply(&self, a: Complex<T>, b: Complex<T>) -> Complex<T> {
        match self.eps {
            None => a * b,
            Some(eps) => a * b.conj() / (b.norm_sqr() + eps),
        }
    }
    /// `g_a` for one pair.
    #[inline(always)]
    fn grad_a(&self, b: Complex<T>, gy: Complex<T>) -> Complex<T> {
        match self.eps {
            None => b.conj() * gy,
            Some(eps) => b * gy / (b.norm_sqr() + eps),
        }
    }
    /// One batch element's contribution to `g_b`.
    #[inline(always)]
    fn grad_b(&self, a: Complex<T>, b: Complex<T>, gy: Complex<T>) -> Complex<T> {
        match self.eps {
            None => a.conj() * gy,
            Some(eps) => {
                let d = b.norm_sqr() + eps;
                (a * gy.conj() * eps - a.conj() * b * b * gy) / (d * d)
            }
        }
    }
}

impl<T: Float> Op<T> for ComplexBinary<T> {
    fn name(&self) -> &'static str {
        if self.eps.is_some() {
            "complex_div_guarded"
        } else {
            "complex_mul"
        }
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        broadcast_len(Op::<T>::name(self), inputs[0].shape(), inputs[1].shape());
        inputs[0].shape()
    }
    fn overwrites_output(&self) -> bool {
        true
    }
    /// `b`, the broadcast operand, is the weight: the frequency response of a learned filter
    /// (the cortex's W). Feedback alignment may send errors back through another `b`.
    fn weight_inputs(&self) -> &'static [usize] {
        &[1]
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (a, b) = (as_complex(inputs[0].data()), as_complex(inputs[1].data()));
        let m = b.len();
        for_chunks(as_complex_mut(out.data_mut()), |start, out| {
            pieces(start, out.len(), m, |i, j, n| {
                let o = &mut out[i - start..][..n];
                for ((o, &a), &b) in o.iter_mut().zip(&a[i..i + n]).zip(&b[j..j + n]) {
                    *o = self.apply(a, b);
                }
            });
        });
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (a, b) = (
            as_complex(cx.inputs[0].data()),
            as_complex(cx.inputs[1].data()),
        );
        let gy = as_complex(cx.dy.data());
        let m = b.len();
        if let Some(ga) = dx.slot_data(0) {
            for_chunks(as_complex_mut(ga), |start, ga| {
                pieces(start, ga.len(), m, |i, j, n| {
                    let g = &mut ga[i - start..][..n];
                    for ((g, &b), &gy) in g.iter_mut().zip(&b[j..j + n]).zip(&gy[i..i + n]) {
                        *g = *g + self.grad_a(b, gy);
                    }
                });
            });
        }
        if let Some(gb) = dx.slot_data(1) {
            let batch = a.len() / m.max(1);
            for_chunks(as_complex_mut(gb), |start, gb| {
                let (len, b) = (gb.len(), &b[start..start + gb.len()]);
                for n in 0..batch {
                    let (a, gy) = (&a[n * m + start..][..len], &gy[n * m + start..][..len]);
                    for (((g, &a), &b), &gy) in gb.iter_mut().zip(a).zip(b).zip(gy) {
                        *g = *g + self.grad_b(a, b, gy);
                    }
                }
            });
        }
    }
}

impl<T: Float> Tape<T> {
    /// Real `(…)` → complex `(…, 2)` with zero imaginary part.
    #[track_caller]
    pub fn to_complex(&mut self, x: Var) -> Var {
        self.apply(ToComplex, &[x])
    }

    /// Complex `(…, 2)` → its real part `(…)`.
    #[track_caller]
    pub fn real_part(&mut self, x: Var) -> Var {
        self.apply(RealPart, &[x])
    }

    /// `a·b` elementwise; `b`'s shape is a suffix of `a`'s and is broadcast over `a`'s leading
    /// axes (e.g. `a` `(B, H, W, 2)`, `b` `(H, W, 2)`).
    #[track_caller]
    pub fn complex_mul(&mut self, a: Var, b: Var) -> Var {
        self.apply(ComplexBinary::<T> { eps: None }, &[a, b])
    }

    /// `a·conj(b) / (|b|² + eps)` elementwise, `b` broadcast as in [`Tape::complex_mul`]: a
    /// division by `b` that stays finite (and differentiable) where `|b| → 0`. The official
    /// code divides unguarded; docs/references.md#guarded-w-inverse recommends `eps = 1e-6`.
    #[track_caller]
    pub fn complex_div_guarded(&mut self, a: Var, b: Var, eps: f64) -> Var {
        assert!(
            eps > 0.0,
            "complex_div_guarded: eps must be positive, got {eps}"
        );
        self.apply(
            ComplexBinary {
                eps: Some(T::of(eps)),
            },
            &[a, b],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> Complex<f64> {
        Complex::new(re, im)
    }

    #[test]
    fn multiply_then_guarded_divide_recovers_a() {
        let a = Tensor::from_fn([3, 2, 2, 2], |i| (i as f64 * 0.37).sin());
        let b = Tensor::from_fn([2, 2, 2], |i| 0.5 + (i as f64 * 1.3).cos());
        let mut tape = Tape::<f64>::new();
        let (va, vb) = (tape.constant(a.clone()), tape.constant(b));
        let ab = tape.complex_mul(va, vb);
        let back = tape.complex_div_guarded(ab, vb, 1e-12);
        assert!(tape.value(back).max_abs_diff(&a) < 1e-9);
    }

    #[test]
    fn values_match_complex_arithmetic() {
        let (a, b) = (c(1.0, 2.0), c(-0.5, 0.25));
        let mut tape = Tape::<f64>::new();
        let va = tape.constant(Tensor::from_vec([1, 1, 1, 2], vec![a.re, a.im]));
        let vb = tape.constant(Tensor::from_vec([1, 1, 2], vec![b.re, b.im]));
        let p = tape.complex_mul(va, vb);
        let q = tape.complex_div_guarded(va, vb, 0.1);
        let (want_p, want_q) = (a * b, a * b.conj() / (b.norm_sqr() + 0.1));
        assert_eq!(tape.value(p).data(), &[want_p.re, want_p.im]);
        let got = tape.value(q).data();
        assert!((got[0] - want_q.re).abs() < 1e-15 && (got[1] - want_q.im).abs() < 1e-15);
        let z = tape.constant(Tensor::from_vec([1, 1, 2], vec![0.0, 0.0]));
        let at_zero = tape.complex_div_guarded(va, z, 1e-6);
        assert_eq!(tape.value(at_zero).data(), &[0.0, 0.0]);
    }

    #[test]
    #[should_panic(
        expected = "complex_mul: the second input (3, 3, 2) must be a complex suffix of the first (2, 4, 4, 2)"
    )]
    fn mismatched_response_panics_with_both_shapes() {
        let mut tape = Tape::<f32>::new();
        let a = tape.constant(Tensor::zeros([2, 4, 4, 2]));
        let b = tape.constant(Tensor::zeros([3, 3, 2]));
        tape.complex_mul(a, b);
    }
}
