//! Losses: the official batch-masked squared error and a plain mean squared error.
//!
//! - `masked_sq_error(pred, target, mask, border_px)`: `pred`, `target`, `mask` all
//!   `(B, C, H, W)` (the cortex uses `C = 1`). Over every site `(c, i, j)` at least `border_px`
//!   from each image edge,
//!   `L = Σ_sites [ Σ_b mask·(pred − target)² ] / ( Σ_b mask + 1 )`,
//!   a per-pixel batch-masked mean summed over pixels — about `H'·W'` × the MSE (authors' code, docs/references.md#loss,
//!   `CortexModel.py`; the official border is ⌊7/2⌋ = 3 px). The mask is data: it gets no
//!   gradient. `∂L/∂pred = 2·mask·(pred − target) / (Σ_b mask + 1)` inside the crop, 0 outside;
//!   `∂L/∂target` is its negative.
//! - `mse(pred, target)`: `mean((pred − target)²)` over all elements, same shapes.
//!
//! Both return a rank-0 scalar. Sums run in f64 for accuracy with f32 tensors; `mse` sums
//! large tensors in parallel over fixed chunks ([`crate::ops::reduce`]), so its value does not
//! depend on the thread count.

use crate::ops::reduce::{chunked_total, lanes_total, TASK_ELEMS};
use crate::{BackwardCx, Float, GradSlots, GradTarget, Op, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["masked_sq_error", "mse"];

/// The official batch-masked squared error over a border-cropped image (see module docs).
#[derive(Debug)]
pub struct MaskedSqError {
    /// Pixels this close to any edge are left out (official: 3).
    pub border_px: usize,
}

/// The sites a [`MaskedSqError`] sums over: `(B, C, H, W)` and the kept rows and columns.
struct Crop {
    b: usize,
    c: usize,
    h: usize,
    w: usize,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
}

impl MaskedSqError {
    fn crop<T: Float>(&self, t: &Tensor<T>) -> Crop {
        let (b, c, h, w) = t.shape().bchw("masked_sq_error");
        let e = self.border_px;
        Crop {
            b,
            c,
            h,
            w,
            rows: e..h.saturating_sub(e).max(e),
            cols: e..w.saturating_sub(e).max(e),
        }
    }
}

impl<T: Float> Op<T> for MaskedSqError {
    fn name(&self) -> &'static str {
        "masked_sq_error"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(
            inputs.len(),
            3,
            "masked_sq_error: takes (pred, target, mask)"
        );
        let (p, t, m) = (inputs[0].shape(), inputs[1].shape(), inputs[2].shape());
        p.bchw("masked_sq_error");
        assert!(
            p == t && p == m,
            "masked_sq_error: pred {p:?}, target {t:?} and mask {m:?} must have one shape"
        );
        Shape::scalar()
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (p, t, m) = (inputs[0].data(), inputs[1].data(), inputs[2].data());
        let Crop {
            b,
            c,
            h,
            w,
            rows,
            cols,
        } = self.crop(inputs[0]);
        let plane = c * h * w;
        let mut total = 0.0f64;
        for ch in 0..c {
            for i in rows.clone() {
                for j in cols.clone() {
                    let site = (ch * h + i) * w + j;
                    let (mut num, mut den) = (0.0f64, 1.0f64);
                    for k in 0..b {
                        let q = k * plane + site;
                        let (d, mk) = ((p[q] - t[q]).as_f64(), m[q].as_f64());
                        num += mk * d * d;
                        den += mk;
                    }
                    total += num / den;
                }
            }
        }
        out.data_mut()[0] = T::of(total);
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (p, t, m) = (
            cx.inputs[0].data(),
            cx.inputs[1].data(),
            cx.inputs[2].data(),
        );
        let Crop {
            b,
            c,
            h,
            w,
            rows,
            cols,
        } = self.crop(cx.inputs[0]);
        let plane = c * h * w;
        let dy = cx.dy.data()[0].as_f64();
        for slot in 0..2 {
            let sign = if slot == 0 { 2.0 } else { -2.0 };
            let Some(g) = dx.slot_data(slot) else {
                continue;
            };
            for ch in 0..c {
                for i in rows.clone() {
                    for j in cols.clone() {
                        let site = (ch * h + i) * w + j;
                        let den = 1.0 + (0..b).map(|k| m[k * plane + site].as_f64()).sum::<f64>();
                        let scale = sign * dy / den;
                        for k in 0..b {
                            let q = k * plane + site;
                            g[q] += T::of(scale * m[q].as_f64() * (p[q] - t[q]).as_f64());
                        }
                    }
                }
            }
        }
    }
}

/// Mean squared error over all elements.
#[derive(Debug, Default)]
pub struct Mse;

impl<T: Float> Op<T> for Mse {
    fn name(&self) -> &'static str {
        "mse"
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "mse: takes (pred, target)");
        let (p, t) = (inputs[0].shape(), inputs[1].shape());
        assert!(
            p == t,
            "mse: pred {p:?} and target {t:?} must have one shape"
        );
        Shape::scalar()
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (p, t) = (inputs[0].data(), inputs[1].data());
        let s = chunked_total(p.len(), |r| {
            let (p, t) = (&p[r.clone()], &t[r]);
            lanes_total(p.len(), |i| (p[i] - t[i]).as_f64().powi(2))
        });
        out.data_mut()[0] = T::of(s / p.len().max(1) as f64);
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (p, t) = (cx.inputs[0].data(), cx.inputs[1].data());
        let scale = T::of(2.0 * cx.dy.data()[0].as_f64() / p.len().max(1) as f64);
        for (slot, sign) in [(0, scale), (1, -scale)] {
            let Some((g, add)) = dx.target(slot).map(GradTarget::into_parts) else {
                continue;
            };
            // g (=|+=) sign·(p − t), in parallel chunks for large tensors.
            let run = |((g, p), t): ((&mut [T], &[T]), &[T])| {
                for ((a, &x), &y) in g.iter_mut().zip(p).zip(t) {
                    *a = if add {
                        *a + sign * (x - y)
                    } else {
                        sign * (x - y)
                    };
                }
            };
            if g.len() <= TASK_ELEMS {
                run(((g, p), t));
            } else {
                let chunks = g.par_chunks_mut(TASK_ELEMS).zip(p.par_chunks(TASK_ELEMS));
                chunks.zip(t.par_chunks(TASK_ELEMS)).for_each(run);
            }
        }
    }
}

impl<T: Float> Tape<T> {
    /// The official cortex loss: `Σ_sites Σ_b mask·(pred − target)² / (Σ_b mask + 1)` over
    /// sites at least `border_px` from every edge; all inputs `(B, C, H, W)`; the mask gets no
    /// gradient. See [`MaskedSqError`].
    #[track_caller]
    pub fn masked_sq_error(&mut self, pred: Var, target: Var, mask: Var, border_px: usize) -> Var {
        self.apply(MaskedSqError { border_px }, &[pred, target, mask])
    }

    /// `mean((pred − target)²)` over all elements; a rank-0 scalar. See [`Mse`].
    #[track_caller]
    pub fn mse(&mut self, pred: Var, target: Var) -> Var {
        self.apply(Mse, &[pred, target])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{check_gradients, check_inputs, strategies as st, CheckConfig};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(st::config())]

        #[test]
        fn masked_sq_error_gradients(
            (p, t, m) in (1usize..=3, 1usize..=2, 1usize..=7, 1usize..=7).prop_flat_map(|(b, c, h, w)| {
                let d = vec![b, c, h, w];
                (st::tensor_of(d.clone()), st::tensor_of(d.clone()),
                 proptest::collection::vec(prop_oneof![Just(0.0), Just(1.0), 0.0f64..1.0], b * c * h * w)
                    .prop_map(move |v| Tensor::from_vec(&d[..], v)))
            }),
            border in 0usize..=2,
        ) {
            let r = check_inputs(|tp, v| tp.masked_sq_error(v[0], v[1], v[2], border), &[p, t, m], &[true, true, false], &CheckConfig::default());
            prop_assert!(r.is_ok(), "border {border}: {}", r.unwrap_err());
        }

        #[test]
        fn mse_gradients((p, t) in (1usize..=3).prop_flat_map(st::dims).prop_flat_map(|d| (st::tensor_of(d.clone()), st::tensor_of(d)))) {
            let r = check_gradients(|tp, v| tp.mse(v[0], v[1]), &[p, t], &CheckConfig::default());
            prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        }
    }

    #[test]
    fn masked_value_by_hand() {
        // B = 2, 1×3×3 images, border 1 keeps the centre pixel only.
        let mut pred = vec![9.0; 18];
        let target = vec![0.0; 18];
        let mut mask = vec![0.0; 18];
        pred[4] = 2.0; // image 0 centre: error² = 4
        pred[13] = 3.0; // image 1 centre: error² = 9
        mask[4] = 1.0;
        mask[13] = 1.0;
        let mut tp = Tape::<f64>::new();
        let (p, t, m) = (
            tp.leaf(Tensor::from_vec([2, 1, 3, 3], pred)),
            tp.constant(Tensor::from_vec([2, 1, 3, 3], target)),
            tp.constant(Tensor::from_vec([2, 1, 3, 3], mask.clone())),
        );
        let l = tp.masked_sq_error(p, t, m, 1);
        // (4 + 9) / (2 + 1)
        assert!((tp.value(l).item() - 13.0 / 3.0).abs() < 1e-15);
        // With image 1 masked out: 4 / (1 + 1).
        mask[13] = 0.0;
        let m2 = tp.constant(Tensor::from_vec([2, 1, 3, 3], mask));
        let l2 = tp.masked_sq_error(p, t, m2, 1);
        assert!((tp.value(l2).item() - 2.0).abs() < 1e-15);
        let e = tp.mse(p, t);
        assert!((tp.value(e).item() - (16.0 * 81.0 + 4.0 + 9.0) / 18.0).abs() < 1e-12);
    }

    /// Past one task (`TASK_ELEMS`), `mse` runs in parallel chunks: the same bits with 1
    /// thread as with 3, the exact value, and gradients written fresh then added (the loss
    /// counted twice) on both inputs.
    #[test]
    fn large_mse_is_exact_deterministic_and_writes_every_gradient() {
        let n = 3 * crate::ops::reduce::TASK_ELEMS + 5;
        let pred = |i: usize| (i % 1000) as f32 - 499.75;
        let target = |i: usize| (i % 7) as f32;
        let run = |threads: usize| {
            crate::ops::reduce::tests::on_threads(threads, || {
                let mut tp = Tape::<f32>::new();
                let p = tp.leaf(Tensor::from_fn([n], pred));
                let t = tp.leaf(Tensor::from_fn([n], target));
                let (a, b) = (tp.mse(p, t), tp.mse(p, t));
                let l = tp.add(a, b);
                tp.backward(l);
                let (gp, gt) = (tp.grad(p).unwrap().clone(), tp.grad(t).unwrap().clone());
                (tp.value(a).item(), gp, gt)
            })
        };
        let (one, gp1, gt1) = run(1);
        let (three, gp3, gt3) = run(3);
        assert_eq!(one.to_bits(), three.to_bits());
        assert!(
            gp1 == gp3 && gt1 == gt3,
            "gradients depend on the thread count"
        );
        let exact: f64 = (0..n).map(|i| ((pred(i) - target(i)) as f64).powi(2)).sum();
        assert_eq!(one, (exact / n as f64) as f32);
        let scale = (2.0 / n as f64) as f32;
        for i in (0..n).step_by(997).chain([n - 1]) {
            let d = scale * (pred(i) - target(i));
            assert_eq!(
                (gp1.data()[i], gt1.data()[i]),
                (2.0 * d, -2.0 * d),
                "element {i}"
            );
        }
    }

    #[test]
    #[should_panic(
        expected = "masked_sq_error: pred (2, 1, 4, 4), target (2, 1, 4, 4) and mask (1, 1, 4, 4) must have one shape"
    )]
    fn masked_shape_mismatch_panics() {
        let mut tp = Tape::<f32>::new();
        let p = tp.constant(Tensor::zeros([2, 1, 4, 4]));
        let m = tp.constant(Tensor::zeros([1, 1, 4, 4]));
        tp.masked_sq_error(p, p, m, 3);
    }

    #[test]
    #[should_panic(expected = "mse: pred (3,) and target (4,) must have one shape")]
    fn mse_shape_mismatch_panics() {
        let mut tp = Tape::<f32>::new();
        let p = tp.constant(Tensor::zeros([3]));
        let q = tp.constant(Tensor::zeros([4]));
        tp.mse(p, q);
    }
}
