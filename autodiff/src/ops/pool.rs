//! `max_pool2x2`: 2×2 max pooling with stride 2.
//!
//! `x (B, C, H, W)` → `(B, C, ⌊H/2⌋, ⌊W/2⌋)`. Like PyTorch's `MaxPool2d(2)` (floor mode), an
//! odd last row or column is dropped. Ties go to the first maximum in row-major window order
//! (top-left, top-right, bottom-left, bottom-right), and NaN propagates as the max. Forward
//! saves the argmax of every window in the op; backward routes `dy` to that pixel only.

use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["max_pool2x2"];

/// 2×2 max pooling, stride 2, floor mode. Saves the window offset (0..4) of each maximum.
#[derive(Debug, Default)]
pub struct MaxPool2x2 {
    argmax: Vec<u8>,
}

impl<T: Float> Op<T> for MaxPool2x2 {
    fn name(&self) -> &'static str {
        "max_pool2x2"
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 1, "max_pool2x2: takes one input");
        let (b, c, h, w) = inputs[0].shape().bchw("max_pool2x2");
        Shape::new(&[b, c, h / 2, w / 2])
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let x = inputs[0];
        let (_, _, h, w) = x.shape().bchw("max_pool2x2");
        let (ho, wo) = (h / 2, w / 2);
        self.argmax.clear();
        self.argmax.resize(out.numel(), 0);
        if ho * wo == 0 {
            return;
        }
        out.data_mut()
            .par_chunks_mut(ho * wo)
            .zip(self.argmax.par_chunks_mut(ho * wo))
            .zip(x.data().par_chunks(h * w))
            .for_each(|((y, arg), xp)| {
                for i in 0..ho {
                    let (r0, r1) = (&xp[2 * i * w..][..w], &xp[(2 * i + 1) * w..][..w]);
                    for j in 0..wo {
                        let win = [r0[2 * j], r0[2 * j + 1], r1[2 * j], r1[2 * j + 1]];
                        let mut best = 0;
                        for (q, &v) in win.iter().enumerate().skip(1) {
                            // A NaN beats every number and then stays the max.
                            if v > win[best] || (v.is_nan() && !win[best].is_nan()) {
                                best = q;
                            }
                        }
                        y[i * wo + j] = win[best];
                        arg[i * wo + j] = best as u8;
                    }
                }
            });
    }

    fn overwrites_output(&self) -> bool {
        true
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (_, _, h, w) = cx.inputs[0].shape().bchw("max_pool2x2");
        let (ho, wo) = (h / 2, w / 2);
        let Some(gx) = dx.slot_data(0) else { return };
        if ho * wo == 0 {
            return;
        }
        gx.par_chunks_mut(h * w)
            .zip(cx.dy.data().par_chunks(ho * wo))
            .zip(self.argmax.par_chunks(ho * wo))
            .for_each(|((gp, dy), arg)| {
                for i in 0..ho {
                    for j in 0..wo {
                        let q = arg[i * wo + j] as usize;
                        gp[(2 * i + q / 2) * w + 2 * j + q % 2] += dy[i * wo + j];
                    }
                }
            });
    }
}

impl<T: Float> Tape<T> {
    /// 2×2 max pooling, stride 2: `(B, C, H, W)` → `(B, C, ⌊H/2⌋, ⌊W/2⌋)`. See [`MaxPool2x2`].
    #[track_caller]
    pub fn max_pool2x2(&mut self, x: Var) -> Var {
        self.apply(MaxPool2x2::default(), &[x])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{check_gradients, strategies as st, CheckConfig};
    use proptest::prelude::*;

    /// Distinct values (a shuffled ramp, spacing 0.1) so no window has a tie: max is smooth.
    fn distinct(dims: Vec<usize>) -> impl Strategy<Value = Tensor<f64>> {
        let n: usize = dims.iter().product();
        Just((0..n).collect::<Vec<_>>())
            .prop_shuffle()
            .prop_map(move |perm| {
                Tensor::from_vec(
                    &dims[..],
                    perm.iter()
                        .map(|&p| p as f64 * 0.1 - n as f64 * 0.05)
                        .collect(),
                )
            })
    }

    proptest! {
        #![proptest_config(st::config())]

        #[test]
        fn max_pool_gradients(x in (1usize..=2, 1usize..=3, 1usize..=7, 1usize..=7)
            .prop_flat_map(|(b, c, h, w)| distinct(vec![b, c, h, w])))
        {
            let r = check_gradients(|t, v| t.max_pool2x2(v[0]), std::slice::from_ref(&x), &CheckConfig::default());
            prop_assert!(r.is_ok(), "max_pool2x2 {:?}: {}", x.shape(), r.unwrap_err());
        }
    }

    #[test]
    fn odd_sizes_floor_and_route_gradient_to_argmax() {
        // 3×5 → 1×2; the last row and column are dropped and get no gradient.
        let x = Tensor::from_vec(
            [1, 1, 3, 5],
            vec![
                1., 9., 2., 3., 50., 4., 5., 8., 0., 60., 70., 80., 90., 99., 99.,
            ],
        );
        let mut t = Tape::<f64>::new();
        let xv = t.leaf(x);
        let y = t.max_pool2x2(xv);
        assert_eq!(t.shape(y), Shape::new(&[1, 1, 1, 2]));
        assert_eq!(t.value(y).data(), &[9., 8.]);
        t.backward_from(
            &[(y, Tensor::from_vec([1, 1, 1, 2], vec![2., 3.]))],
            &mut crate::NoHooks,
        );
        let mut want = [0.0; 15];
        want[1] = 2.0;
        want[7] = 3.0;
        assert_eq!(t.grad(xv).unwrap().data(), &want[..]);
    }

    #[test]
    fn ties_pick_the_first_and_nan_propagates() {
        let mut t = Tape::<f32>::new();
        let x = t.leaf(Tensor::from_vec(
            [1, 1, 2, 4],
            vec![3., 3., 1., f32::NAN, 3., 1., 2., 0.],
        ));
        let y = t.max_pool2x2(x);
        assert_eq!(t.value(y).data()[0], 3.0);
        assert!(t.value(y).data()[1].is_nan());
        t.backward_from(
            &[(y, Tensor::from_vec([1, 1, 1, 2], vec![1.0, 1.0]))],
            &mut crate::NoHooks,
        );
        assert_eq!(t.grad(x).unwrap().data(), &[1., 0., 0., 1., 0., 0., 0., 0.]);
    }

    #[test]
    #[should_panic(expected = "max_pool2x2: expected a (B, C, H, W) tensor, got (4, 4)")]
    fn rank_mismatch_panics() {
        let mut t = Tape::<f32>::new();
        let x = t.constant(Tensor::zeros([4, 4]));
        t.max_pool2x2(x);
    }
}
