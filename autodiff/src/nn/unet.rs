//! The U-Net demosaicker D of the cortex (authors' code, docs/references.md#d-bucket, `Cx/D_demosaicing/D_Default.py`).
//!
//! Shapes: `x (B, in_channels, H, W)` → `(B, out_channels, H, W)`; `H` and `W` must be
//! divisible by `2^(levels − 1)` where `levels = widths.len()`.
//!
//! Architecture, for widths `w₀ < w₁ < … < w_L`:
//! - `DoubleConv(a → b)` = [3×3 conv, no bias, reflect padding → ReLU] × 2 (no BatchNorm).
//! - Encoder: `inc = DoubleConv(in → w₀)`, then for each level `MaxPool2 → DoubleConv(wᵢ₋₁ → wᵢ)`.
//! - Decoder, for each level back up: `ConvTranspose 2×2 stride 2 (with bias) wᵢ → wᵢ₋₁`,
//!   concatenate `[skip, up]` (skip first), `DoubleConv(2·wᵢ₋₁ → wᵢ₋₁)`.
//! - Out: 1×1 conv `w₀ → out` with bias; no output activation, no residual.
//!
//! Official: 8 → 16/32/64/128 → 8 (3 pooling levels), 482 168 parameters; the Sandbox
//! variant 16/32/64 has 117 560. Initialisation is PyTorch's default (Kaiming-uniform with
//! a = √5): weights and biases `U(±1/√fan_in)`, `fan_in = Cin·k²` for a conv and `Cout·k²`
//! for a transposed conv (PyTorch reads fan-in from weight axis 1).
//!
//! Parameter names (under `prefix`): `inc.conv{0,1}.weight`, `down{i}.conv{0,1}.weight`,
//! `up{i}.up.weight`, `up{i}.up.bias`, `up{i}.conv{0,1}.weight`, `outc.weight`, `outc.bias`;
//! `i` counts from 1, `up1` being the deepest.
//!
//! Tags ([`crate::scopes`]): each DoubleConv's output is tagged `unet.inc`, `unet.down` or
//! `unet.up`, the hidden layers a layer-wise learning rule acts on.

use crate::ops::conv::Padding;
use crate::{Float, ParamId, ParamStore, Tape, Tensor, Var};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Sizes of a [`UNet`].
#[derive(Clone, Debug, PartialEq)]
pub struct UNetConfig {
    /// Input channels (official: N = 8 cone-type channels).
    pub in_channels: usize,
    /// Output channels (official: 8).
    pub out_channels: usize,
    /// Channel width per level, shallowest first; `widths.len() − 1` pooling levels.
    pub widths: Vec<usize>,
    /// Seed of the initial weights.
    pub seed: u64,
}

impl UNetConfig {
    /// The official demosaicker: 8 → 16/32/64/128 → 8 (authors' code, docs/references.md#d-bucket).
    pub fn official() -> Self {
        UNetConfig {
            in_channels: 8,
            out_channels: 8,
            widths: vec![16, 32, 64, 128],
            seed: 0,
        }
    }

    /// The Sandbox variant, two pooling levels: 8 → 16/32/64 → 8 (authors' code, docs/references.md#d-bucket).
    pub fn quick() -> Self {
        UNetConfig {
            widths: vec![16, 32, 64],
            ..Self::official()
        }
    }
}

/// Two bias-free reflect-padded 3×3 convolutions, each followed by ReLU.
#[derive(Clone, Debug)]
struct DoubleConv {
    w: [ParamId; 2],
}

/// One decoder stage: transposed conv up (with bias), skip concat, DoubleConv.
#[derive(Clone, Debug)]
struct Up {
    weight: ParamId,
    bias: ParamId,
    conv: DoubleConv,
}

/// The U-Net demosaicker; holds parameter ids into a [`ParamStore`] (see the module docs).
#[derive(Clone, Debug)]
pub struct UNet {
    config: UNetConfig,
    inc: DoubleConv,
    downs: Vec<DoubleConv>,
    ups: Vec<Up>,
    out_weight: ParamId,
    out_bias: ParamId,
}

/// How a forward pass turns a parameter id into a tape variable.
type ParamFn<'a, T> = dyn FnMut(&mut Tape<T>, ParamId) -> Var + 'a;

/// `U(±bound)` samples of `shape`.
fn uniform<T: Float>(rng: &mut StdRng, shape: &[usize], bound: f64) -> Tensor<T> {
    Tensor::from_fn(shape, |_| T::of(rng.random_range(-bound..bound)))
}

impl DoubleConv {
    fn new<T: Float>(
        ps: &mut ParamStore<T>,
        rng: &mut StdRng,
        name: &str,
        cin: usize,
        cout: usize,
    ) -> Self {
        let mut conv = |i: usize, ci: usize| {
            let w = uniform(rng, &[cout, ci, 3, 3], 1.0 / ((ci * 9) as f64).sqrt());
            ps.add(format!("{name}.conv{i}.weight"), w)
        };
        DoubleConv {
            w: [conv(0, cin), conv(1, cout)],
        }
    }

    fn forward<T: Float>(&self, tape: &mut Tape<T>, param: &mut ParamFn<'_, T>, mut x: Var) -> Var {
        for &id in &self.w {
            let w = param(tape, id);
            // One fused op: relu(conv2d(x, w)).
            x = tape.conv2d_relu(x, w, Padding::Reflect);
        }
        x
    }
}

impl UNet {
    /// Creates the parameters in `params` under `prefix` with PyTorch's default initialisation.
    #[track_caller]
    pub fn new<T: Float>(params: &mut ParamStore<T>, prefix: &str, config: UNetConfig) -> Self {
        let ws = &config.widths;
        assert!(!ws.is_empty(), "UNet: widths must not be empty");
        let mut rng = StdRng::seed_from_u64(config.seed);
        let inc = DoubleConv::new(
            params,
            &mut rng,
            &format!("{prefix}.inc"),
            config.in_channels,
            ws[0],
        );
        let downs = (1..ws.len())
            .map(|i| {
                DoubleConv::new(
                    params,
                    &mut rng,
                    &format!("{prefix}.down{i}"),
                    ws[i - 1],
                    ws[i],
                )
            })
            .collect();
        let ups = (1..ws.len())
            .rev()
            .enumerate()
            .map(|(k, i)| {
                let name = format!("{prefix}.up{}", k + 1);
                let (cin, cout) = (ws[i], ws[i - 1]);
                let bound = 1.0 / ((cout * 4) as f64).sqrt();
                let weight = params.add(
                    format!("{name}.up.weight"),
                    uniform(&mut rng, &[cin, cout, 2, 2], bound),
                );
                let bias = params.add(format!("{name}.up.bias"), uniform(&mut rng, &[cout], bound));
                let conv = DoubleConv::new(params, &mut rng, &name, 2 * cout, cout);
                Up { weight, bias, conv }
            })
            .collect();
        let bound = 1.0 / (ws[0] as f64).sqrt();
        let out_weight = params.add(
            format!("{prefix}.outc.weight"),
            uniform(&mut rng, &[config.out_channels, ws[0], 1, 1], bound),
        );
        let out_bias = params.add(
            format!("{prefix}.outc.bias"),
            uniform(&mut rng, &[config.out_channels], bound),
        );
        UNet {
            config,
            inc,
            downs,
            ups,
            out_weight,
            out_bias,
        }
    }

    /// The configuration it was built with.
    pub fn config(&self) -> &UNetConfig {
        &self.config
    }

    /// Every parameter id, in creation order.
    pub fn param_ids(&self) -> Vec<ParamId> {
        let mut ids: Vec<ParamId> = self.inc.w.to_vec();
        ids.extend(self.downs.iter().flat_map(|d| d.w));
        for u in &self.ups {
            ids.extend([u.weight, u.bias]);
            ids.extend(u.conv.w);
        }
        ids.extend([self.out_weight, self.out_bias]);
        ids
    }

    /// Total number of scalar parameters.
    pub fn num_params<T: Float>(&self, params: &ParamStore<T>) -> usize {
        self.param_ids()
            .iter()
            .map(|&id| params.get(id).numel())
            .sum()
    }

    /// Records the network on `tape`: `x (B, in_channels, H, W)` → `(B, out_channels, H, W)`.
    #[track_caller]
    pub fn forward<T: Float>(&self, tape: &mut Tape<T>, params: &ParamStore<T>, x: Var) -> Var {
        self.forward_with(tape, x, |t, id| params.var(t, id))
    }

    /// Like [`UNet::forward`], but each parameter comes from `param(tape, id)`: substitute
    /// perturbed or externally owned weights, or record them as checked leaves in tests.
    #[track_caller]
    pub fn forward_with<T: Float>(
        &self,
        tape: &mut Tape<T>,
        x: Var,
        mut param: impl FnMut(&mut Tape<T>, ParamId) -> Var,
    ) -> Var {
        let param: &mut ParamFn<'_, T> = &mut param;
        let s = tape.shape(x);
        let (_, c, h, w) = s.bchw("UNet");
        let m = 1 << self.downs.len();
        assert!(
            c == self.config.in_channels && h % m == 0 && w % m == 0,
            "UNet: input {s:?} does not fit (want {} channels, H and W divisible by {m})",
            self.config.in_channels
        );
        let mut skips = Vec::with_capacity(self.downs.len());
        let mut h = self.inc.forward(tape, param, x);
        tape.tag(h, "unet.inc");
        for down in &self.downs {
            skips.push(h);
            let p = tape.max_pool2x2(h);
            h = down.forward(tape, param, p);
            tape.tag(h, "unet.down");
        }
        for (up, skip) in self.ups.iter().zip(skips.into_iter().rev()) {
            let (wt, bt) = (param(tape, up.weight), param(tape, up.bias));
            // One fused op: conv_transpose2x2(h, wt) + bt per channel.
            let u = tape.conv_transpose2x2_bias(h, wt, bt);
            let cat = tape.concat(&[skip, u]);
            h = up.conv.forward(tape, param, cat);
            tape.tag(h, "unet.up");
        }
        let (wo, bo) = (param(tape, self.out_weight), param(tape, self.out_bias));
        let y = tape.conv2d(h, wo, Padding::Zero);
        tape.add_channel_bias(y, bo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{check_gradients, CheckConfig};
    use crate::learn::ParamGrads;
    use crate::optim::{Adam, Optimizer};
    use std::f64::consts::TAU;

    #[test]
    fn parameter_counts_match_the_official_model() {
        let mut ps = ParamStore::<f32>::new();
        let net = UNet::new(&mut ps, "d", UNetConfig::official());
        assert_eq!(net.num_params(&ps), 482_168);
        assert_eq!(ps.numel(), 482_168);
        let mut ps = ParamStore::<f32>::new();
        let net = UNet::new(&mut ps, "d", UNetConfig::quick());
        assert_eq!(net.num_params(&ps), 117_560);
        assert_eq!(ps.name(net.param_ids()[0]), "d.inc.conv0.weight");
        assert!(ps.find("d.up1.up.bias").is_some() && ps.find("d.outc.bias").is_some());
    }

    #[test]
    fn init_follows_pytorch_bounds() {
        let mut ps = ParamStore::<f64>::new();
        UNet::new(&mut ps, "d", UNetConfig::quick());
        for (name, bound) in [
            ("d.inc.conv0.weight", 1.0 / 72f64.sqrt()),
            ("d.up1.up.weight", 1.0 / 128f64.sqrt()),
            ("d.up2.up.bias", 1.0 / 64f64.sqrt()),
            ("d.outc.weight", 0.25),
        ] {
            let t = ps.get(ps.find(name).unwrap());
            let max = t.data().iter().fold(0.0f64, |m, &v| m.max(v.abs()));
            assert!(
                max < bound && max > 0.8 * bound,
                "{name}: max |w| {max}, bound {bound}"
            );
        }
    }

    #[test]
    fn forward_shape_and_gradient_of_a_tiny_net() {
        let cfg = UNetConfig {
            in_channels: 2,
            out_channels: 3,
            widths: vec![2, 3],
            seed: 1,
        };
        let mut ps = ParamStore::<f64>::new();
        let net = UNet::new(&mut ps, "u", cfg);
        let ids = net.param_ids();
        let mut inputs = vec![Tensor::from_fn([2, 2, 4, 6], |i| {
            ((i * 7919) % 97) as f64 / 48.0 - 1.0
        })];
        inputs.extend(ids.iter().map(|&id| ps.get(id).clone()));
        // Every parameter is a checked input: v[0] is x, v[k + 1] is parameter ids[k].
        let r = check_gradients(
            |t, v| {
                net.forward_with(t, v[0], |_, id| {
                    v[1 + ids.iter().position(|&i| i == id).unwrap()]
                })
            },
            &inputs,
            &CheckConfig::default(),
        );
        assert!(r.is_ok(), "{}", r.unwrap_err());
        let mut t = Tape::<f64>::new();
        let x = t.constant(inputs[0].clone());
        let y = net.forward(&mut t, &ps, x);
        assert_eq!(t.shape(y), crate::Shape::new(&[2, 3, 4, 6]));
    }

    #[test]
    #[should_panic(
        expected = "UNet: input (1, 8, 12, 16) does not fit (want 8 channels, H and W divisible by 8)"
    )]
    fn indivisible_size_panics() {
        let mut ps = ParamStore::<f32>::new();
        let net = UNet::new(&mut ps, "d", UNetConfig::official());
        let mut t = Tape::<f32>::new();
        let x = t.constant(Tensor::zeros([1, 8, 12, 16]));
        net.forward(&mut t, &ps, x);
    }

    /// Smooth random RGB images and their mosaic: each pixel keeps one of 3 colours (a fixed
    /// random pattern), given to the net as 3 channels that are zero where not sampled.
    fn mosaic_batch(
        rng: &mut StdRng,
        pattern: &[usize],
        b: usize,
        s: usize,
    ) -> (Tensor<f32>, Tensor<f32>) {
        let mut full = Tensor::<f32>::zeros([b, 3, s, s]);
        for img in full.data_mut().chunks_exact_mut(s * s) {
            let (fx, fy) = (rng.random_range(0.5..2.0), rng.random_range(0.5..2.0));
            let (px, py, base) = (
                rng.random_range(0.0..6.3),
                rng.random_range(0.0..6.3),
                rng.random_range(0.2..0.8),
            );
            let amp = rng.random_range(0.1..0.3);
            for (q, v) in img.iter_mut().enumerate() {
                let (i, j) = ((q / s) as f64 / s as f64, (q % s) as f64 / s as f64);
                *v = (base + amp * ((TAU * fx * i + px).sin() * (TAU * fy * j + py).cos())) as f32;
            }
        }
        let mut mosaic = Tensor::<f32>::zeros([b, 3, s, s]);
        for (q, m) in mosaic.data_mut().iter_mut().enumerate() {
            let (ch, px) = ((q / (s * s)) % 3, q % (s * s));
            if pattern[px] == ch {
                *m = full.data()[q];
            }
        }
        (mosaic, full)
    }

    #[test]
    fn learns_to_demosaic_smooth_images() {
        let s = 16;
        let mut rng = StdRng::seed_from_u64(42);
        let pattern: Vec<usize> = (0..s * s).map(|_| rng.random_range(0..3)).collect();
        let mut ps = ParamStore::<f32>::new();
        let cfg = UNetConfig {
            in_channels: 3,
            out_channels: 3,
            widths: vec![8, 16],
            seed: 3,
        };
        let net = UNet::new(&mut ps, "d", cfg);
        let mut opt = Optimizer::new(Adam::new(3e-3));
        let (test_x, test_y) = mosaic_batch(&mut rng, &pattern, 8, s);
        let mut tape = Tape::<f32>::new();
        let eval = |tape: &mut Tape<f32>, ps: &ParamStore<f32>| {
            tape.clear();
            let (x, y) = (tape.constant(test_x.clone()), tape.constant(test_y.clone()));
            let out = net.forward(tape, ps, x);
            let l = tape.mse(out, y);
            tape.value(l).item()
        };
        let before = eval(&mut tape, &ps);
        let mut grads = ParamGrads::new();
        let start = std::time::Instant::now();
        for _ in 0..150 {
            let (bx, by) = mosaic_batch(&mut rng, &pattern, 8, s);
            tape.clear();
            let (x, y) = (tape.constant(bx), tape.constant(by));
            let out = net.forward(&mut tape, &ps, x);
            let l = tape.mse(out, y);
            tape.backward(l);
            grads.fill_from_tape(&tape);
            opt.step(&mut ps, &grads).unwrap();
        }
        let after = eval(&mut tape, &ps);
        eprintln!(
            "demosaic: test MSE {before:.4} → {after:.5} in {:?}",
            start.elapsed()
        );
        assert!(
            after * 10.0 <= before,
            "test MSE fell only from {before} to {after}"
        );
    }
}
