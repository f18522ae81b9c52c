//! Direct feedback alignment (Nøkland 2016, *NeurIPS*, arXiv:1609.01596): the output error
//! `e = ∂L/∂y` is sent straight to every tagged hidden layer through a fixed random matrix,
//! `δh_k = B_k·e`, instead of travelling back through the layers above.
//!
//! Mechanics, on one reverse sweep from the loss:
//! - the model names its output ([`Objective::output`]) and tags its hidden activations
//!   ([`Tape::tag`]); untagged nodes get their ordinary VJP;
//! - when the sweep reaches the output, its gradient `e` is kept;
//! - when it reaches a tagged activation `h_k`, the gradient that arrived from above is
//!   *replaced* by `B_k·e`; it then flows on through the layer's own ops (so the local
//!   derivative `f′(a_k)` and the layer's weights `dW_k = x_kᵀ·δa_k` are as in the paper) down
//!   to the next tagged activation below, where it is replaced again. Layers above the output
//!   (the loss itself) and tags met before the output is reached keep backprop.
//!
//! `B_k`'s structure, for an activation of shape `A` and an output of shape `E` (batch first):
//! - both `(B, features)`: dense, `(m, p)` for `m` output and `p` hidden features, as the paper;
//! - both `(B, C, H, W)`: a random `(C_e, C)` channel mix applied at each location to the error
//!   resampled to the activation's grid (block mean when the layer is coarser, repetition when
//!   it is finer). A dense `B` for images is `C·H·W × C_e·H_e·W_e` (8·64² × 64² = 134 M entries
//!   for the `quick` cortex, per layer), and the error of an image predictor is local: the
//!   feedback keeps it where it occurred. This is a restriction of the paper's `B`, stated so.
//!   Any other pair of shapes panics, naming the tag and both shapes.
//!
//! Entries are `N(0, 1/m)` (`m` = output features per location), so `‖B·e‖ ≈ ‖e‖` per
//! location. Each `B_k` is drawn from a generator seeded by the rule's seed and a hash of the
//! tag's name and both shapes: it depends on nothing trained, so a resumed run draws exactly
//! the matrices of the run that never stopped.
//!
//! Sign convention: what is returned is used like `∂L/∂θ` (optimisers subtract it).

use super::{LearningRule, Objective, ParamGrads};
use crate::tape::{BackwardHooks, NodeView};
use crate::{Float, ParamStore, Tape, Tensor};
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use std::collections::{BTreeMap, HashMap};

/// A feedback matrix's key: tag, activation dims and output dims without the batch axis.
type Key = (&'static str, Vec<usize>, Vec<usize>);

/// Direct feedback alignment with fixed random feedback matrices, one per tagged layer.
pub struct DirectFeedbackAlignment<T: Float = f32> {
    seed: u64,
    feedback: BTreeMap<Key, Tensor<T>>,
}

impl<T: Float> DirectFeedbackAlignment<T> {
    /// A rule whose feedback matrices are drawn from `seed`.
    pub fn new(seed: u64) -> Self {
        DirectFeedbackAlignment {
            seed,
            feedback: BTreeMap::new(),
        }
    }

    /// The matrix of `key`: `(m, p)` dense or `(C_e, C)` channel mix (module docs).
    fn matrix(&mut self, key: Key) -> &Tensor<T> {
        let seed = self.seed;
        self.feedback.entry(key).or_insert_with_key(|(tag, a, e)| {
            let (rows, cols) = match (a.len(), e.len()) {
                (1, 1) => (e[0], a[0]),
                (3, 3) => (e[0], a[0]),
                _ => panic!(
                    "DirectFeedbackAlignment: tag {tag}: activation (B, {a:?}) and output \
                     (B, {e:?}) are neither both (B, features) nor both (B, C, H, W)"
                ),
            };
            // FNV-1a over the key, then SplitMix-style mixing with the seed.
            let mut h: u64 = 0xcbf2_9ce4_8422_2325;
            let bytes = tag.bytes().chain(
                a.iter()
                    .chain([&usize::MAX])
                    .chain(e.iter())
                    .flat_map(|d| d.to_le_bytes()),
            );
            for byte in bytes {
                h = (h ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
            }
            let mut s = seed ^ h.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            s = (s ^ (s >> 31)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            let mut rng = StdRng::seed_from_u64(s);
            let sigma = 1.0 / (rows.max(1) as f64).sqrt();
            Tensor::from_fn([rows, cols], |_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                T::of(sigma * z)
            })
        })
    }

    /// Writes `B·e` into `grad` (shape of the tagged activation).
    fn project(&mut self, tag: &'static str, e: &Tensor<T>, grad: &mut Tensor<T>) {
        let (a, ed) = (grad.dims().to_vec(), e.dims().to_vec());
        assert_eq!(
            a[0], ed[0],
            "DirectFeedbackAlignment: tag {tag}: batch of activation {a:?} and output {ed:?}"
        );
        let key = (tag, a[1..].to_vec(), ed[1..].to_vec());
        let m = self.matrix(key).clone();
        let (rows, cols) = (m.dims()[0], m.dims()[1]);
        let (bm, ev) = (m.data(), e.data());
        let g = grad.data_mut();
        if a.len() == 2 {
            for b in 0..a[0] {
                for (j, gj) in g[b * cols..(b + 1) * cols].iter_mut().enumerate() {
                    *gj = (0..rows).map(|r| ev[b * rows + r] * bm[r * cols + j]).sum();
                }
            }
            return;
        }
        let (h, w, he, we) = (a[2], a[3], ed[2], ed[3]);
        let coarser = he % h == 0 && we % w == 0;
        assert!(
            coarser || (h % he == 0 && w % we == 0),
            "DirectFeedbackAlignment: tag {tag}: activation grid {h}×{w} and output grid \
             {he}×{we} are not integer multiples"
        );
        let mut local = vec![T::zero(); rows];
        for b in 0..a[0] {
            for y in 0..h {
                for x in 0..w {
                    for (r, l) in local.iter_mut().enumerate() {
                        let plane = &ev[(b * rows + r) * he * we..(b * rows + r + 1) * he * we];
                        *l = if coarser {
                            let (fy, fx) = (he / h, we / w);
                            let mut acc = T::zero();
                            for yy in y * fy..(y + 1) * fy {
                                for xx in x * fx..(x + 1) * fx {
                                    acc += plane[yy * we + xx];
                                }
                            }
                            acc / T::of((fy * fx) as f64)
                        } else {
                            plane[(y * he / h) * we + x * we / w]
                        };
                    }
                    for c in 0..cols {
                        g[((b * cols + c) * h + y) * w + x] =
                            (0..rows).map(|r| local[r] * bm[r * cols + c]).sum();
                    }
                }
            }
        }
    }
}

struct Hooks<'a, T: Float> {
    rule: &'a mut DirectFeedbackAlignment<T>,
    output: usize,
    tags: HashMap<usize, &'static str>,
    error: Option<Tensor<T>>,
}

impl<T: Float> BackwardHooks<T> for Hooks<'_, T> {
    fn on_grad(&mut self, node: &NodeView<'_, T>, grad: &mut Tensor<T>) {
        let i = node.var.index();
        if i == self.output {
            self.error = Some(grad.clone());
        } else if let (Some(&tag), Some(e)) = (self.tags.get(&i), &self.error) {
            self.rule.project(tag, e, grad);
        }
    }
}

impl<T: Float> LearningRule<T> for DirectFeedbackAlignment<T> {
    fn assign_credit_into(
        &mut self,
        tape: &mut Tape<T>,
        objective: Objective,
        _params: &ParamStore<T>,
        grads: &mut ParamGrads<T>,
    ) {
        let output = objective.output.expect(
            "DirectFeedbackAlignment: the objective names no output (Objective::with_output)",
        );
        let tags = tape
            .tags()
            .iter()
            .map(|&(name, v)| (v.index(), name))
            .collect();
        let mut hooks = Hooks {
            rule: self,
            output: output.index(),
            tags,
            error: None,
        };
        tape.backward_with(objective.loss, &mut hooks);
        grads.fill_from_tape(tape);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A (2, 2, 4, 4) activation fed back from a (2, 1, 8, 8) output: block means, then the
    /// channel mix; a finer activation repeats the error.
    #[test]
    fn image_feedback_is_a_channel_mix_of_the_resampled_error() {
        let mut dfa = DirectFeedbackAlignment::<f64>::new(3);
        let e = Tensor::from_fn([2, 1, 8, 8], |i| (i as f64 * 0.3).sin());
        let mut g = Tensor::zeros([2, 2, 4, 4]);
        dfa.project("h", &e, &mut g);
        let r = dfa.feedback.values().next().unwrap().clone();
        assert_eq!(r.dims(), &[1, 2]);
        let mean = (e.data()[64 + 2 * 8 + 2]
            + e.data()[64 + 2 * 8 + 3]
            + e.data()[64 + 3 * 8 + 2]
            + e.data()[64 + 3 * 8 + 3])
            / 4.0;
        // sample 1, channel 1, cell (1, 1)
        let got = g.data()[((2 + 1) * 4 + 1) * 4 + 1];
        assert!((got - mean * r.data()[1]).abs() < 1e-12);
        let mut fine = Tensor::zeros([2, 2, 16, 16]);
        dfa.project("h", &e, &mut fine);
        assert!(
            (fine.data()[16 + 1] - e.data()[0] * dfa.feedback.values().nth(1).unwrap().data()[0])
                .abs()
                < 1e-12
        );
    }

    #[test]
    fn feedback_depends_only_on_seed_tag_and_shapes() {
        let e = Tensor::from_fn([3, 2], |i| i as f64 - 2.0);
        let proj = |seed: u64, tag: &'static str| {
            let mut g = Tensor::zeros([3, 5]);
            DirectFeedbackAlignment::<f64>::new(seed).project(tag, &e, &mut g);
            g
        };
        assert_eq!(proj(1, "a"), proj(1, "a"));
        assert_ne!(proj(1, "a"), proj(2, "a"));
        assert_ne!(proj(1, "a"), proj(1, "b"));
    }

    #[test]
    #[should_panic(expected = "tag h: activation (B, [4]) and output (B, [1, 2, 2])")]
    fn mixed_ranks_panic_naming_the_tag() {
        let mut g = Tensor::zeros([1, 4]);
        DirectFeedbackAlignment::<f64>::new(1).project("h", &Tensor::zeros([1, 1, 2, 2]), &mut g);
    }
}
