//! `max_pool2x2`: 2×2 max pooling with stride 2.
//!
//! `x (B, C, H, W)` → `(B, C, ⌊H/2⌋, ⌊W/2⌋)`. Like PyTorch's `MaxPool2d(2)` (floor mode), an
//! odd last row or column is dropped. Ties go to the first maximum in row-major window order
//! (top-left, top-right, bottom-left, bottom-right), and NaN propagates as the max (the first
//! NaN of a window is its argmax). Backward routes `dy` to the argmax pixel only.
//!
//! Forward computes each window's max and argmax branch-free as a tournament (the two pairs of
//! the window, then their winners, the left one winning ties), which picks the same pixel as
//! the sequential rule above, and saves the argmax (one byte per window, in a buffer recycled
//! across ops) for backward. Both passes run in parallel over chunks of `(b, c)` planes.

use crate::{BackwardCx, Float, GradSlots, Op, Shape, Tape, Tensor, Var};
use rayon::prelude::*;
use std::sync::Mutex;

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["max_pool2x2"];

/// Input elements per parallel task, at least: below this rayon's overhead dominates.
const MIN_TASK_ELEMS: usize = 1 << 15;

/// Argmax buffers of dropped ops, reused by later ones (fresh pages are slow on these VMs).
static ARGMAX_STASH: Mutex<Vec<Vec<u8>>> = Mutex::new(Vec::new());

/// Most buffers the stash keeps.
const STASH_MAX: usize = 16;

/// 2×2 max pooling, stride 2, floor mode (see the module docs). Saves the window offset (0..4,
/// row-major) of each maximum.
#[derive(Debug, Default)]
pub struct MaxPool2x2 {
    argmax: Vec<u8>,
}

impl Drop for MaxPool2x2 {
    fn drop(&mut self) {
        let buf = std::mem::take(&mut self.argmax);
        if buf.capacity() > 0 {
            let mut stash = ARGMAX_STASH.lock().unwrap_or_else(|e| e.into_inner());
            if stash.len() < STASH_MAX {
                stash.push(buf);
            }
        }
    }
}

/// A buffer of `n` bytes (contents unspecified), from the stash when one is large enough.
fn take_argmax(n: usize) -> Vec<u8> {
    let mut stash = ARGMAX_STASH.lock().unwrap_or_else(|e| e.into_inner());
    let best = (0..stash.len())
        .filter(|&i| stash[i].capacity() >= n)
        .min_by_key(|&i| stash[i].capacity());
    let mut buf = best.map_or_else(Vec::new, |i| stash.swap_remove(i));
    drop(stash);
    buf.resize(n, 0);
    buf
}

/// `(max, 1 if b won)` of `a` then `b`: `b` wins when larger, or NaN while `a` is not; so ties
/// go to `a` and NaN beats every number.
#[inline(always)]
fn duel<T: Float>(a: T, b: T) -> (T, u8) {
    // Non-short-circuit `|` and `&` keep this a select, not a branch.
    let b_wins = (b > a) | (b.is_nan() & !a.is_nan());
    (if b_wins { b } else { a }, b_wins as u8)
}

/// Pools one `(h, w)` plane `xp` into `y` and `arg` (`⌊h/2⌋ × wo` each).
fn pool_plane<T: Float>(xp: &[T], y: &mut [T], arg: &mut [u8], w: usize, wo: usize) {
    let rows = y.chunks_exact_mut(wo).zip(arg.chunks_exact_mut(wo));
    for (i, (yr, ar)) in rows.enumerate() {
        let r0 = &xp[2 * i * w..][..2 * wo];
        let r1 = &xp[(2 * i + 1) * w..][..2 * wo];
        let wins = r0.chunks_exact(2).zip(r1.chunks_exact(2));
        for ((o, q), (a, b)) in yr.iter_mut().zip(ar.iter_mut()).zip(wins) {
            let (top, qt) = duel(a[0], a[1]);
            let (bottom, qb) = duel(b[0], b[1]);
            let (m, lower) = duel(top, bottom);
            *o = m;
            // lower ? 2 + qb : qt, as bit operations (u8 lanes vectorise, selects may not).
            let lm = lower.wrapping_neg();
            *q = (lower << 1) | (qb & lm) | (qt & !lm);
        }
    }
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
        if ho * wo == 0 {
            return;
        }
        let mut argmax = take_argmax(out.numel());
        let planes = (MIN_TASK_ELEMS / (h * w)).max(1);
        let (n_in, n_out) = (planes * h * w, planes * ho * wo);
        out.data_mut()
            .par_chunks_mut(n_out)
            .zip(argmax.par_chunks_mut(n_out))
            .zip(x.data().par_chunks(n_in))
            .for_each(|((ys, args), xs)| {
                let per_plane = ys
                    .chunks_exact_mut(ho * wo)
                    .zip(args.chunks_exact_mut(ho * wo))
                    .zip(xs.chunks_exact(h * w));
                for ((yp, ap), xp) in per_plane {
                    pool_plane(xp, yp, ap, w, wo);
                }
            });
        self.argmax = argmax;
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
        let planes = (MIN_TASK_ELEMS / (h * w)).max(1);
        let (n_in, n_out) = (planes * h * w, planes * ho * wo);
        gx.par_chunks_mut(n_in)
            .zip(cx.dy.data().par_chunks(n_out))
            .zip(self.argmax.par_chunks(n_out))
            .for_each(|((gs, dys), args)| {
                let per_plane = gs
                    .chunks_exact_mut(h * w)
                    .zip(dys.chunks_exact(ho * wo))
                    .zip(args.chunks_exact(ho * wo));
                for ((gp, dy), arg) in per_plane {
                    for i in 0..ho {
                        let (g0, g1) = gp[2 * i * w..][..2 * w].split_at_mut(w);
                        let (dr, ar) = (&dy[i * wo..][..wo], &arg[i * wo..][..wo]);
                        for (j, (&d, &q)) in dr.iter().zip(ar).enumerate() {
                            let row = if q < 2 { &mut *g0 } else { &mut *g1 };
                            row[2 * j + (q & 1) as usize] += d;
                        }
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

    /// The forward rule written out plainly: value and window offset of the first maximum,
    /// a NaN beating every number.
    fn reference(x: &Tensor<f32>) -> (Vec<f32>, Vec<usize>) {
        let (b, c, h, w) = x.shape().bchw("reference");
        let (ho, wo) = (h / 2, w / 2);
        let (mut vals, mut at) = (vec![], vec![]);
        for p in 0..b * c {
            for i in 0..ho {
                for j in 0..wo {
                    let idx = |q: usize| p * h * w + (2 * i + q / 2) * w + 2 * j + q % 2;
                    let mut best = 0;
                    for q in 1..4 {
                        let (v, m) = (x.data()[idx(q)], x.data()[idx(best)]);
                        if v > m || (v.is_nan() && !m.is_nan()) {
                            best = q;
                        }
                    }
                    vals.push(x.data()[idx(best)]);
                    at.push(idx(best));
                }
            }
        }
        (vals, at)
    }

    #[test]
    fn matches_the_plain_rule_with_ties_nans_and_signed_zeros() {
        // Few distinct values, so most windows tie; several planes per parallel task and
        // several tasks (MIN_TASK_ELEMS), odd sizes.
        let palette = [0.0f32, -0.0, 1.0, 1.0, -2.0, f32::NAN];
        let mut seed = 7u64;
        let x = Tensor::from_fn([3, 5, 37, 41], |_| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            palette[(seed >> 33) as usize % palette.len()]
        });
        let (vals, at) = reference(&x);
        let mut t = Tape::<f32>::new();
        let xv = t.leaf(x.clone());
        let y = t.max_pool2x2(xv);
        for (k, (&got, &want)) in t.value(y).data().iter().zip(&vals).enumerate() {
            assert!(
                got == want || (got.is_nan() && want.is_nan()),
                "window {k}: {got} vs {want}"
            );
        }
        let dy = Tensor::from_fn(t.shape(y), |k| k as f32 + 1.0);
        t.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
        let mut want = vec![0.0f32; x.numel()];
        for (k, &i) in at.iter().enumerate() {
            want[i] += dy.data()[k];
        }
        assert_eq!(t.grad(xv).unwrap().data(), &want[..]);
    }

    #[test]
    #[should_panic(expected = "max_pool2x2: expected a (B, C, H, W) tensor, got (4, 4)")]
    fn rank_mismatch_panics() {
        let mut t = Tape::<f32>::new();
        let x = t.constant(Tensor::zeros([4, 4]));
        t.max_pool2x2(x);
    }
}
