//! `conv_transpose2x2`: transposed convolution, kernel 2, stride 2 (the U-Net's up-sampling),
//! with an optional per-channel bias.
//!
//! `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)` (PyTorch `ConvTranspose2d` layout), optionally
//! `b (Cout,)` → `y (B, Cout, 2H, 2W)`, `y[b,o,2i+a,2j+c] = b[o] + Σ_ci x[b,ci,i,j] · w[ci,o,a,c]`
//! (`b[o] = 0` for the two-input form).
//! With `M = w` viewed as `Cin × (Cout·4)`, one image is the GEMM `Z = Mᵀ · x_b`
//! (`(Cout·4) × HW`) followed by a pixel shuffle `Z[(o,a,c), (i,j)] → y[o, 2i+a, 2j+c]` that
//! also adds the bias. Backward un-shuffles `dy` into `dZ`, then `∂x_b += M · dZ`,
//! `∂M += x_b · dZᵀ` and `∂b[o] += Σ_pixels dy[b,o,·,·]`, images in parallel.

use super::scratch::Scratch;
use crate::op::write_or_add;
use crate::ops::reduce::lane_sum;
use crate::{BackwardCx, Float, GradSlots, GradTarget, Op, Shape, Tape, Tensor, Var};
use rayon::prelude::*;

/// The stride-2, 2×2 transposed convolution (see the module docs). Applied to `(x, w)` it has
/// no bias ([`Tape::conv_transpose2x2`]); applied to `(x, w, b)` it adds `b` per output
/// channel ([`Tape::conv_transpose2x2_bias`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct ConvTranspose2x2;

/// `(batch, cin, cout, h, w)` after checking the shapes (and the bias, when given).
#[track_caller]
fn dims(x: Shape, w: Shape, b: Option<Shape>) -> (usize, usize, usize, usize, usize) {
    let (batch, c, h, wd) = x.bchw("conv_transpose2x2");
    let (ci, co, k0, k1) = w.bchw("conv_transpose2x2 weight");
    assert!(
        ci == c && k0 == 2 && k1 == 2,
        "conv_transpose2x2: input {x:?} and weight {w:?} do not fit (want weight ({c}, Cout, 2, 2))"
    );
    if let Some(b) = b {
        assert!(
            b.rank() == 1 && b.dim(0) == co,
            "conv_transpose2x2: bias {b:?} does not fit weight {w:?} (want ({co},))"
        );
    }
    (batch, c, co, h, wd)
}

/// `img[o, 2i+a, 2j+c] = z[(o·4 + a·2 + c)·hw + i·w + j] + bias[o]` for one image: each output
/// row interleaves two rows of `z`, written once, front to back.
fn shuffle<T: Float>(z: &[T], y: &mut [T], bias: Option<&[T]>, co: usize, h: usize, w: usize) {
    let hw = h * w;
    for (o, yo) in y.chunks_exact_mut(4 * hw).enumerate() {
        for (r, row) in yo.chunks_exact_mut(2 * w).enumerate() {
            let (i, a) = (r / 2, r % 2);
            let z0 = &z[(o * 4 + a * 2) * hw + i * w..][..w];
            let z1 = &z[(o * 4 + a * 2 + 1) * hw + i * w..][..w];
            let pairs = row.chunks_exact_mut(2).zip(z0).zip(z1);
            match bias {
                Some(b) => {
                    let bo = b[o];
                    for ((p, &u), &v) in pairs {
                        p[0] = u + bo;
                        p[1] = v + bo;
                    }
                }
                None => {
                    for ((p, &u), &v) in pairs {
                        p[0] = u;
                        p[1] = v;
                    }
                }
            }
        }
    }
    debug_assert_eq!(y.len(), co * 4 * hw);
}

/// The inverse of [`shuffle`] without bias: `z[(o·4 + a·2 + c)·hw + i·w + j] = img[o, 2i+a, 2j+c]`.
fn unshuffle<T: Float>(y: &[T], z: &mut [T], co: usize, h: usize, w: usize) {
    let hw = h * w;
    for (o, yo) in y.chunks_exact(4 * hw).enumerate() {
        for (r, row) in yo.chunks_exact(2 * w).enumerate() {
            let (i, a) = (r / 2, r % 2);
            let (z0, z1) = z[(o * 4 + a * 2) * hw..][..2 * hw].split_at_mut(hw);
            let (z0, z1) = (&mut z0[i * w..][..w], &mut z1[i * w..][..w]);
            for ((p, u), v) in row.chunks_exact(2).zip(z0).zip(z1) {
                *u = p[0];
                *v = p[1];
            }
        }
    }
    debug_assert_eq!(y.len(), co * 4 * hw);
}

/// Writes (fresh target) or adds (accumulating target) the sum of `parts` into `g`.
fn reduce_into<'p, T: Float>(g: GradTarget<'_, T>, parts: impl Iterator<Item = &'p [T]>) {
    let (g, mut add) = g.into_parts();
    for p in parts {
        write_or_add(g, p, add);
        add = true;
    }
    if !add {
        g.fill(T::zero());
    }
}

impl<T: Float> Op<T> for ConvTranspose2x2 {
    fn name(&self) -> &'static str {
        "conv_transpose2x2"
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert!(
            matches!(inputs.len(), 2 | 3),
            "conv_transpose2x2: takes (x, w) or (x, w, b)"
        );
        let b = inputs.get(2).map(|b| b.shape());
        let (batch, _, co, h, w) = dims(inputs[0].shape(), inputs[1].shape(), b);
        Shape::new(&[batch, co, 2 * h, 2 * w])
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (x, w) = (inputs[0], inputs[1]);
        let bias = inputs.get(2).map(|b| b.data());
        let (_, ci, co, h, wd) = dims(x.shape(), w.shape(), inputs.get(2).map(|b| b.shape()));
        let hw = h * wd;
        let ws = w.data();
        out.data_mut()
            .par_chunks_mut(co * 4 * hw)
            .zip(x.data().par_chunks(ci * hw))
            .for_each_init(
                || Scratch::<T>::take(co * 4 * hw),
                |z, (y, xb)| {
                    T::gemm(z, false, ws, true, xb, false, co * 4, hw, ci, T::one());
                    shuffle(z, y, bias, co, h, wd);
                },
            );
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (x, w, dy) = (cx.inputs[0], cx.inputs[1], cx.dy);
        let has_bias = cx.inputs.len() == 3;
        let (batch, ci, co, h, wd) =
            dims(x.shape(), w.shape(), cx.inputs.get(2).map(|b| b.shape()));
        let hw = h * wd;
        let (xs, ws, dys) = (x.data(), w.data(), dy.data());
        let (want_w, want_b) = (dx.wants(1), has_bias && dx.wants(2));
        // Per image: its ∂x chunk (if wanted) and whether to add into it.
        let mut gx_chunks: Vec<Option<(&mut [T], bool)>> = match dx.target(0) {
            Some(g) => {
                let (g, acc) = g.into_parts();
                g.chunks_mut(ci * hw).map(|c| Some((c, acc))).collect()
            }
            None => (0..batch).map(|_| None).collect(),
        };
        // Per worker: ∂w (ci·co·4) then ∂b (co), summed over its images.
        let part_len = if want_w { ci * co * 4 } else { 0 } + if want_b { co } else { 0 };
        let partials: Vec<Option<Scratch<T>>> = gx_chunks
            .par_iter_mut()
            .enumerate()
            .fold(
                || (Scratch::<T>::take(co * 4 * hw), None),
                |(mut dz, mut part), (b, gx)| {
                    let dyb = &dys[b * co * 4 * hw..(b + 1) * co * 4 * hw];
                    unshuffle(dyb, &mut dz, co, h, wd);
                    if let Some((gx, acc)) = gx.as_mut() {
                        T::gemm(gx, *acc, ws, false, &dz, false, ci, hw, co * 4, T::one());
                    }
                    if part_len > 0 {
                        let p: &mut Scratch<T> =
                            part.get_or_insert_with(|| Scratch::zeroed(part_len));
                        let (pw, pb) = p.split_at_mut(if want_w { ci * co * 4 } else { 0 });
                        if want_w {
                            let xb = &xs[b * ci * hw..(b + 1) * ci * hw];
                            T::gemm(pw, true, xb, false, &dz, true, ci, co * 4, hw, T::one());
                        }
                        for (a, plane) in pb.iter_mut().zip(dyb.chunks_exact(4 * hw)) {
                            *a += lane_sum(plane);
                        }
                    }
                    (dz, part)
                },
            )
            .map(|(_, p)| p)
            .collect();
        drop(gx_chunks);
        let split = if want_w { ci * co * 4 } else { 0 };
        if let Some(g) = dx.target(1) {
            reduce_into(g, partials.iter().flatten().map(|p| &p[..split]));
        }
        if let (true, Some(g)) = (want_b, dx.target(2)) {
            reduce_into(g, partials.iter().flatten().map(|p| &p[split..]));
        }
    }

    fn overwrites_output(&self) -> bool {
        true
    }

    fn weight_inputs(&self) -> &'static [usize] {
        &[1]
    }
}

impl<T: Float> Tape<T> {
    /// Transposed convolution, kernel 2, stride 2, plus a per-channel bias, as one op:
    /// `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)`, `b (Cout,)` → `(B, Cout, 2H, 2W)`. Equals
    /// `add_channel_bias(conv_transpose2x2(x, w), b)` (PyTorch `ConvTranspose2d(Cin, Cout, 2,
    /// stride=2)`) without the extra passes. See [`ConvTranspose2x2`].
    #[track_caller]
    pub fn conv_transpose2x2_bias(&mut self, x: Var, w: Var, b: Var) -> Var {
        self.apply(ConvTranspose2x2, &[x, w, b])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{check_gradients, strategies as st, CheckConfig};
    use proptest::prelude::*;

    /// `y[b,o,2i+a,2j+c] = bias[o] + Σ_ci x[b,ci,i,j] · w[ci,o,a,c]`, written out.
    fn naive(x: &Tensor<f64>, w: &Tensor<f64>, bias: &[f64]) -> Tensor<f64> {
        let (bn, ci, h, wd) = x.shape().bchw("ref");
        let co = w.dims()[1];
        Tensor::from_fn([bn, co, 2 * h, 2 * wd], |f| {
            let (b, o) = (f / (co * 4 * h * wd), (f / (4 * h * wd)) % co);
            let (r, q) = ((f / (2 * wd)) % (2 * h), f % (2 * wd));
            let (i, a, j, c) = (r / 2, r % 2, q / 2, q % 2);
            bias[o]
                + (0..ci)
                    .map(|k| {
                        x.data()[((b * ci + k) * h + i) * wd + j]
                            * w.data()[((k * co + o) * 2 + a) * 2 + c]
                    })
                    .sum::<f64>()
        })
    }

    /// `(x, w, b)` of small random sizes.
    fn case() -> impl Strategy<Value = (Tensor<f64>, Tensor<f64>, Tensor<f64>)> {
        (1usize..=2, 1usize..=3, 1usize..=3, 1usize..=3, 1usize..=4).prop_flat_map(
            |(bn, ci, co, h, w)| {
                (
                    st::tensor_of(vec![bn, ci, h, w]),
                    st::tensor_of(vec![ci, co, 2, 2]),
                    st::tensor_of(vec![co]),
                )
            },
        )
    }

    proptest! {
        #![proptest_config(st::config())]

        #[test]
        fn conv_transpose2x2_bias_gradients((x, w, b) in case()) {
            let r = check_gradients(
                |t, v| t.conv_transpose2x2_bias(v[0], v[1], v[2]),
                &[x.clone(), w.clone(), b.clone()],
                &CheckConfig::default(),
            );
            prop_assert!(r.is_ok(), "conv_transpose2x2 + bias x {:?} w {:?}: {}", x.shape(), w.shape(), r.unwrap_err());
        }

        /// `x`, `w` and `b` each feed two ops, so the later op's backward gets fresh gradient
        /// buffers (overwritten) and the earlier one accumulates.
        #[test]
        fn conv_transpose2x2_gradients_into_shared_inputs((x, w, b) in case()) {
            let r = check_gradients(
                |t, v| {
                    let y = t.conv_transpose2x2_bias(v[0], v[1], v[2]);
                    let z = t.conv_transpose2x2(v[0], v[1]);
                    let z = t.add_channel_bias(z, v[2]);
                    t.mul(y, z)
                },
                &[x.clone(), w.clone(), b.clone()],
                &CheckConfig::default(),
            );
            prop_assert!(r.is_ok(), "conv_transpose2x2 shared x {:?} w {:?}: {}", x.shape(), w.shape(), r.unwrap_err());
        }

        #[test]
        fn matches_direct_loops_and_the_unfused_pair((x, w, b) in case()) {
            let mut t = Tape::<f64>::new();
            let (xv, wv, bv) = (t.constant(x.clone()), t.constant(w.clone()), t.constant(b.clone()));
            let fused = t.conv_transpose2x2_bias(xv, wv, bv);
            let plain = t.conv_transpose2x2(xv, wv);
            let pair = t.add_channel_bias(plain, bv);
            let zeros = vec![0.0; b.numel()];
            prop_assert!(t.value(fused).max_abs_diff(&naive(&x, &w, b.data())) < 1e-12);
            prop_assert!(t.value(plain).max_abs_diff(&naive(&x, &w, &zeros)) < 1e-12);
            prop_assert!(t.value(fused).max_abs_diff(t.value(pair)) == 0.0);
        }
    }

    #[test]
    fn bias_gradient_sums_over_batch_and_pixels() {
        // Batch 3, 20×18 input (several image chunks for rayon): ∂b[o] = Σ dy[·, o, ·, ·].
        let mut t = Tape::<f64>::new();
        let x = t.constant(Tensor::from_fn([3, 2, 20, 18], |i| (i % 7) as f64 - 3.0));
        let w = t.constant(Tensor::from_fn([2, 3, 2, 2], |i| i as f64 * 0.1));
        let b = t.leaf(Tensor::from_vec([3], vec![1.0, -2.0, 0.5]));
        let y = t.conv_transpose2x2_bias(x, w, b);
        let dy = Tensor::from_fn(t.shape(y), |i| ((i * 31) % 11) as f64 - 5.0);
        let mut want = [0.0; 3];
        for (i, &d) in dy.data().iter().enumerate() {
            want[(i / (40 * 36)) % 3] += d;
        }
        t.backward_from(&[(y, dy)], &mut crate::NoHooks);
        assert_eq!(t.grad(b).unwrap().data(), &want[..]);
    }

    #[test]
    #[should_panic(
        expected = "conv_transpose2x2: bias (3,) does not fit weight (2, 4, 2, 2) (want (4,))"
    )]
    fn bias_mismatch_panics() {
        let mut t = Tape::<f32>::new();
        let x = t.constant(Tensor::zeros([1, 2, 2, 2]));
        let w = t.constant(Tensor::zeros([2, 4, 2, 2]));
        let b = t.constant(Tensor::zeros([3]));
        t.conv_transpose2x2_bias(x, w, b);
    }
}
