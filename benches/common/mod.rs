//! Helpers shared by the criterion benches: a fixed-cotangent "loss" and seeded noise tensors.

use autodiff::{BackwardCx, GradSlots, Op, Shape, Tensor};
use std::cell::RefCell;
use std::sync::Arc;

/// A scalar "loss" of value 0 whose backward hands a fixed cotangent `r` to its input (one
/// copy into the gradient buffer, as a real loss writes its gradient once).
#[allow(dead_code)] // not every bench uses it
pub struct InjectGrad(pub Arc<Tensor<f32>>);

impl Op<f32> for InjectGrad {
    fn name(&self) -> &'static str {
        "inject_grad_bench"
    }
    fn output_shape(&self, _inputs: &[&Tensor<f32>]) -> Shape {
        Shape::scalar()
    }
    fn forward(&mut self, _inputs: &[&Tensor<f32>], _out: &mut Tensor<f32>) {}
    fn backward(&self, _cx: &BackwardCx<'_, f32>, dx: &mut GradSlots<'_, f32>) {
        if let Some(g) = dx.target(0) {
            g.write(self.0.data());
        }
    }
}

/// Like [`InjectGrad`] but hands over an owned cotangent (made before the clock starts) with
/// [`GradSlots::give`]: no copy, as PyTorch's `y.backward(r)` uses `r` as it is.
#[allow(dead_code)] // not every bench uses it
pub struct GiveGrad(pub RefCell<Option<Tensor<f32>>>);

impl Op<f32> for GiveGrad {
    fn name(&self) -> &'static str {
        "give_grad_bench"
    }
    fn output_shape(&self, _inputs: &[&Tensor<f32>]) -> Shape {
        Shape::scalar()
    }
    fn forward(&mut self, _inputs: &[&Tensor<f32>], _out: &mut Tensor<f32>) {}
    fn backward(&self, _cx: &BackwardCx<'_, f32>, dx: &mut GradSlots<'_, f32>) {
        let r = self.0.borrow_mut().take();
        dx.give(0, r.expect("GiveGrad: one backward per recording"));
    }
}

pub fn noise(shape: &[usize], seed: u64) -> Tensor<f32> {
    let mut s = seed;
    Tensor::from_fn(shape, |_| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    })
}
