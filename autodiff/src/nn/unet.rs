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
//! Layers and blocks, for learning rules that act on them ([`crate::scopes`]):
//! - every layer's output is tagged with the layer's parameter name without `.weight`:
//!   `{prefix}.inc.conv0`, `{prefix}.down1.conv1`, `{prefix}.up1.up` (the transposed conv),
//!   `{prefix}.outc` — one tag per layer, so a rule such as direct feedback alignment gives
//!   each its own feedback;
//! - with [`UNet::with_block_scopes`], each block is recorded in a scope of its own:
//!   `{bucket}.inc`, `{bucket}.down{i}`, `{bucket}.up{i}` (an up block holds its transposed
//!   conv, the concatenation and its DoubleConv; the last one also the 1×1 output conv), so a
//!   layer-local rule such as forward-forward keeps each block's learning inside it.
//!   [`UNet::forward_blocks`] returns every block's output.

use crate::ops::conv::Padding;
use crate::scopes::intern;
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
    /// The tags of the two layers' outputs.
    tags: [&'static str; 2],
}

/// One decoder stage: transposed conv up (with bias), skip concat, DoubleConv.
#[derive(Clone, Debug)]
struct Up {
    weight: ParamId,
    bias: ParamId,
    /// The tag of the transposed conv's output.
    tag: &'static str,
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
    out_tag: &'static str,
    /// Scope of each block (inc, downs, ups), when recorded in scopes of their own.
    block_scopes: Option<Vec<&'static str>>,
}

/// What [`UNet::forward_blocks`] leaves on the tape.
#[derive(Clone, Debug)]
pub struct UNetActivations {
    /// The network's output `(B, out_channels, H, W)`.
    pub output: Var,
    /// Each block's output in forward order (inc, downs, ups); the last block ends with the
    /// 1×1 output conv, so its entry is `output`.
    pub blocks: Vec<Var>,
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
            tags: [0, 1].map(|i| intern(&format!("{name}.conv{i}"))),
        }
    }

    fn forward<T: Float>(&self, tape: &mut Tape<T>, param: &mut ParamFn<'_, T>, mut x: Var) -> Var {
        for (&id, &tag) in self.w.iter().zip(&self.tags) {
            let w = param(tape, id);
            // One fused op: relu(conv2d(x, w)).
            x = tape.conv2d_relu(x, w, Padding::Reflect);
            tape.tag(x, tag);
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
                let tag = intern(&format!("{name}.up"));
                Up {
                    weight,
                    bias,
                    tag,
                    conv,
                }
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
            out_tag: intern(&format!("{prefix}.outc")),
            block_scopes: None,
        }
    }

    /// The same network recording each block in a scope of its own, `{bucket}.inc`,
    /// `{bucket}.down{i}`, `{bucket}.up{i}` (module docs).
    pub fn with_block_scopes(mut self, bucket: &str) -> Self {
        let mut names = vec![intern(&format!("{bucket}.inc"))];
        names.extend((1..=self.downs.len()).map(|i| intern(&format!("{bucket}.down{i}"))));
        names.extend((1..=self.ups.len()).map(|i| intern(&format!("{bucket}.up{i}"))));
        self.block_scopes = Some(names);
        self
    }

    /// The scopes of the blocks, in forward order, when recorded in scopes of their own.
    pub fn block_scopes(&self) -> Option<&[&'static str]> {
        self.block_scopes.as_deref()
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
        self.record(tape, x, &mut param).output
    }

    /// Like [`UNet::forward`], returning every block's output too.
    #[track_caller]
    pub fn forward_blocks<T: Float>(
        &self,
        tape: &mut Tape<T>,
        params: &ParamStore<T>,
        x: Var,
    ) -> UNetActivations {
        self.record(tape, x, &mut |t, id| params.var(t, id))
    }

    /// Like [`UNet::forward`], but only the outputs in `out_box` `(B, out_channels, box rows,
    /// box columns)`, equal to the whole input's there: the decoder computes each up block
    /// only where those outputs reach (window module docs).
    #[track_caller]
    pub fn forward_box<T: Float>(
        &self,
        tape: &mut Tape<T>,
        params: &ParamStore<T>,
        x: Var,
        out_box: OutputBox,
    ) -> Var {
        self.record_boxed(tape, x, &mut |t, id| params.var(t, id), Some(out_box))
            .output
    }

    /// Enters the scope of block `k`, when blocks have scopes.
    fn enter_block<T: Float>(&self, tape: &mut Tape<T>, k: usize) {
        if let Some(names) = &self.block_scopes {
            tape.enter_scope(names[k]);
        }
    }

    #[track_caller]
    fn record<T: Float>(
        &self,
        tape: &mut Tape<T>,
        x: Var,
        param: &mut ParamFn<'_, T>,
    ) -> UNetActivations {
        self.record_boxed(tape, x, param, None)
    }

    /// [`UNet::record`], with the decoder computing only what the outputs in `out_box` need
    /// when one is given (the output is then that box: window module docs).
    #[track_caller]
    fn record_boxed<T: Float>(
        &self,
        tape: &mut Tape<T>,
        x: Var,
        param: &mut ParamFn<'_, T>,
        out_box: Option<OutputBox>,
    ) -> UNetActivations {
        let s = tape.shape(x);
        let (_, c, h_in, w_in) = s.bchw("UNet");
        let m = 1 << self.downs.len();
        assert!(
            c == self.config.in_channels && h_in % m == 0 && w_in % m == 0,
            "UNet: input {s:?} does not fit (want {} channels, H and W divisible by {m})",
            self.config.in_channels
        );
        let mut skips = Vec::with_capacity(self.downs.len());
        let mut blocks = Vec::with_capacity(1 + 2 * self.downs.len());
        self.enter_block(tape, 0);
        let mut h = self.inc.forward(tape, param, x);
        blocks.push(h);
        for (k, down) in self.downs.iter().enumerate() {
            skips.push(h);
            self.enter_block(tape, 1 + k);
            let p = tape.max_pool2x2(h);
            h = down.forward(tape, param, p);
            blocks.push(h);
        }
        let crops = out_box.map(|b| self.up_crops(b, h_in, w_in));
        for (k, (up, skip)) in self.ups.iter().zip(skips.into_iter().rev()).enumerate() {
            self.enter_block(tape, 1 + self.downs.len() + k);
            let (lower, skip) = match &crops {
                Some(c) => c.cut_inputs(tape, self.downs.len() - 1 - k, h, skip),
                None => (h, skip),
            };
            let (wt, bt) = (param(tape, up.weight), param(tape, up.bias));
            // One fused op: conv_transpose2x2(h, wt) + bt per channel.
            let u = tape.conv_transpose2x2_bias(lower, wt, bt);
            tape.tag(u, up.tag);
            let cat = tape.concat(&[skip, u]);
            h = up.conv.forward(tape, param, cat);
            blocks.push(h);
        }
        if let Some(c) = &crops {
            h = c.cut_output(tape, h);
        }
        let (wo, bo) = (param(tape, self.out_weight), param(tape, self.out_bias));
        let y = tape.conv2d(h, wo, Padding::Zero);
        let output = tape.add_channel_bias(y, bo);
        tape.tag(output, self.out_tag);
        *blocks.last_mut().expect("the inc block") = output;
        UNetActivations { output, blocks }
    }
}

#[cfg(test)]
mod tests;
mod window;
pub use window::OutputBox;
