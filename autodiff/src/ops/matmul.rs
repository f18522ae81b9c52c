//! Matrix product on faer's GEMM, and the dense layer built on it.
//!
//! - [`Matmul`]: `y = a · b` for rank-2 `a (m, k)` and `b (k, n)` → `(m, n)`, all row-major.
//!   Backward, also through GEMM: `da += dy · bᵀ`, `db += aᵀ · dy`. Nothing is saved beyond the
//!   inputs the tape already owns.
//! - **Weight convention:** rows are samples, so a layer is `x @ W` with `x (batch, in)` and
//!   `W (in, out)`: [`Op::weight_inputs`] is `[1]`, the right operand. Learning rules such as
//!   [`FeedbackAlignment`](crate::learn::FeedbackAlignment) swap that operand in the backward
//!   pass only, and only when it is a parameter. Put the weight on the right to make it visible
//!   to them.
//! - [`Tape::linear`] is `x @ w + b` with `b (n,)` broadcast over the rows (a composite of
//!   `matmul` and `add_broadcast`, not a separate op).
//!
//! Inner dimensions that disagree panic naming the op and both shapes.

use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};

/// Names of the ops in this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["matmul"];

/// `y = a · b`, `(m, k) @ (k, n) → (m, n)`; input 1 is the weight.
#[derive(Clone, Copy, Debug, Default)]
pub struct Matmul;

#[track_caller]
fn mkn<T: Float>(inputs: &[&Tensor<T>]) -> (usize, usize, usize) {
    assert_eq!(
        inputs.len(),
        2,
        "matmul: takes two inputs, got {}",
        inputs.len()
    );
    let (a, b) = (inputs[0].shape(), inputs[1].shape());
    assert!(
        a.rank() == 2 && b.rank() == 2 && a.dim(1) == b.dim(0),
        "matmul: lhs {a:?} and rhs {b:?} do not form (m, k) @ (k, n)"
    );
    (a.dim(0), a.dim(1), b.dim(1))
}

impl<T: Float> Op<T> for Matmul {
    fn name(&self) -> &'static str {
        "matmul"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let (m, _, n) = mkn(inputs);
        Shape::new(&[m, n])
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (m, k, n) = mkn(inputs);
        T::gemm(
            out.data_mut(),
            false,
            inputs[0].data(),
            false,
            inputs[1].data(),
            false,
            m,
            n,
            k,
            T::one(),
        );
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (m, k, n) = mkn(cx.inputs);
        let (a, b, dy) = (cx.inputs[0].data(), cx.inputs[1].data(), cx.dy.data());
        if let Some(ga) = dx.slot_data(0) {
            // (m, n) @ (n, k): b read transposed.
            T::gemm(ga, true, dy, false, b, true, m, k, n, T::one());
        }
        if let Some(gb) = dx.slot_data(1) {
            // (k, m) @ (m, n): a read transposed.
            T::gemm(gb, true, a, true, dy, false, k, n, m, T::one());
        }
    }
    fn weight_inputs(&self) -> &'static [usize] {
        &[1]
    }
}

impl<T: Float> Tape<T> {
    /// `a @ b` for `a (m, k)`, `b (k, n)`. The right operand counts as the weight.
    #[track_caller]
    pub fn matmul(&mut self, a: Var, b: Var) -> Var {
        self.apply(Matmul, &[a, b])
    }

    /// A dense layer `x @ w + b`: `x (batch, in)`, `w (in, out)`, `b (out,)` → `(batch, out)`.
    #[track_caller]
    pub fn linear(&mut self, x: Var, w: Var, b: Var) -> Var {
        let out = self.shape(w).dims().get(1).copied();
        let bias = self.shape(b);
        assert!(
            bias.rank() == 1 && Some(bias.dim(0)) == out,
            "linear: bias {bias:?} does not match weight {:?} (want (out,))",
            self.shape(w)
        );
        let y = self.matmul(x, w);
        self.add_broadcast(y, b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{check_gradients, strategies as st, CheckConfig};
    use proptest::prelude::*;

    fn operands() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>)> {
        st::dims(3).prop_flat_map(|d| {
            (
                st::tensor_of(vec![d[0], d[1]]),
                st::tensor_of(vec![d[1], d[2]]),
            )
        })
    }

    proptest! {
        #![proptest_config(st::config())]

        #[test]
        fn matmul_gradient((a, b) in operands()) {
            let r = check_gradients(|t, v| t.matmul(v[0], v[1]), &[a, b], &CheckConfig::default());
            prop_assert!(r.is_ok(), "matmul: {}", r.unwrap_err());
        }

        #[test]
        fn linear_gradient((x, w) in operands(), seed in any::<u64>()) {
            let n = w.dims()[1];
            let b = Tensor::from_fn([n], |i| ((seed >> (i % 60)) & 7) as f64 * 0.25 - 1.0);
            let r = check_gradients(|t, v| t.linear(v[0], v[1], v[2]), &[x, w, b], &CheckConfig::default());
            prop_assert!(r.is_ok(), "linear: {}", r.unwrap_err());
        }
    }

    #[test]
    fn matmul_gradient_large_uses_probes() {
        // 12×9 and 9×11 exceed max_full_elems: exercises the probe path (and GEMM's kernels).
        let a = Tensor::from_fn([12, 9], |i| ((i * 7) % 13) as f64 / 6.5 - 1.0);
        let b = Tensor::from_fn([9, 11], |i| ((i * 5) % 17) as f64 / 8.5 - 1.0);
        check_gradients(
            |t, v| t.matmul(v[0], v[1]),
            &[a, b],
            &CheckConfig::default(),
        )
        .unwrap();
    }

    #[test]
    fn values_match_naive_product() {
        let a = Tensor::from_fn([3, 4], |i| i as f32 * 0.5 - 2.0);
        let b = Tensor::from_fn([4, 2], |i| 1.0 - i as f32 * 0.25);
        let mut t = Tape::<f32>::new();
        let (av, bv) = (t.constant(a.clone()), t.constant(b.clone()));
        let y = t.matmul(av, bv);
        for i in 0..3 {
            for j in 0..2 {
                let want: f32 = (0..4)
                    .map(|k| a.data()[i * 4 + k] * b.data()[k * 2 + j])
                    .sum();
                assert!((t.value(y).data()[i * 2 + j] - want).abs() < 1e-5);
            }
        }
    }

    #[test]
    #[should_panic(expected = "matmul: lhs (2, 3) and rhs (4, 5) do not form (m, k) @ (k, n)")]
    fn inner_mismatch_names_shapes() {
        let mut t = Tape::<f32>::new();
        let a = t.constant(Tensor::zeros([2, 3]));
        let b = t.constant(Tensor::zeros([4, 5]));
        t.matmul(a, b);
    }
}
