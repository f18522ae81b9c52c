//! Convolutions: `conv2d` ("same" output, stride 1, odd square kernel, zero or reflect
//! padding, no bias) and `conv_transpose2x2` (stride 2, kernel 2, PyTorch weight layout).
//!
//! Shapes (row-major, NCHW):
//! - `conv2d(x, w, padding)`: `x (B, Cin, H, W)`, `w (Cout, Cin, k, k)` with odd `k` →
//!   `(B, Cout, H, W)`. `y[b,o,i,j] = Σ_{c,a,b'} w[o,c,a,b'] · x_pad[b,c,i+a−p,j+b'−p]`,
//!   `p = (k−1)/2` — a cross-correlation, as in PyTorch. Bias is a separate op
//!   ([`Tape::add_channel_bias`]).
//! - `conv_transpose2x2(x, w)`: `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)` → `(B, Cout, 2H, 2W)`,
//!   `y[b,o,2i+a,2j+c] = Σ_ci x[b,ci,i,j] · w[ci,o,a,c]` (each output pixel has one source);
//!   `conv_transpose2x2_bias(x, w, b)` adds `b[o]` in the same pass (PyTorch's
//!   `ConvTranspose2d` with bias, as the U-Net uses it).
//!
//! Both declare their kernel as the weight input (`weight_inputs() == [1]`), so feedback
//! alignment can substitute a fixed random kernel in backward.
//!
//! `conv2d_relu(x, w, padding)` is `relu(conv2d(x, w, padding))` as one op (the U-Net's
//! building block): the ReLU is applied while the output is written, and its backward masks
//! `dy` by `y > 0` while `dy` is being re-laid out anyway, so it costs no extra pass.
//!
//! Implementation: two paths, with identical results up to rounding.
//! - Direct (`direct`, 3×3 kernels on x86-64 CPUs with AVX-512F, f32 and f64): each image is
//!   padded once, then register-blocked micro-kernels (`kernels`) accumulate blocks of 8
//!   output channels × 3 vectors of output pixels over input channels and taps, writing `y`
//!   (with the ReLU) directly; `∂x` is the same kernel over the padded `dy` with the flipped
//!   kernel (plus the reflect border), `∂w` a reduction over pixels vectorised over output
//!   channels of a channels-last copy of `dy`.
//! - GEMM lowering (`gemm_path`, any odd `k`, any CPU): `k²` accumulating faer GEMMs over
//!   shifted views of the padded image.
//!
//! [`ConvKernel`] picks the path per op (default: direct where available). Both run images in
//! parallel on rayon, take scratch from a reused stash (`lowering`), and do not zero-fill the
//! output first ([`Op::overwrites_output`]).

#[cfg(target_arch = "x86_64")]
mod kernels;

mod direct;
mod gemm_path;
mod lowering;
mod scratch;
mod transpose;

pub use lowering::Padding;
pub use transpose::ConvTranspose2x2;

use crate::{BackwardCx, Float, GradSlots, GradTarget, Op, Shape, Tape, Tensor, Var};
use lowering::Geometry;
use scratch::Scratch;
use std::any::Any;
use std::sync::atomic::{AtomicU8, Ordering};

/// Op names of this file (registry rule, see [`crate::ops`]).
pub const OPS: &[&str] = &["conv2d", "conv2d_relu", "conv_transpose2x2"];

/// Which implementation a [`Conv2d`] runs (results agree up to floating-point rounding).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ConvKernel {
    /// The process default ([`set_default_conv_kernel`]; initially the direct kernels where
    /// available, else GEMM).
    #[default]
    Auto,
    /// The GEMM lowering (any kernel size, any CPU).
    Gemm,
    /// The direct micro-kernels; falls back to GEMM when unavailable (kernel not 3×3, or a CPU
    /// without AVX-512F — see [`direct_conv_available`]).
    Direct,
}

/// The kernel [`ConvKernel::Auto`] ops use, as `ConvKernel as u8`.
static DEFAULT_KERNEL: AtomicU8 = AtomicU8::new(ConvKernel::Direct as u8);

/// Sets the kernel of every [`ConvKernel::Auto`] conv2d op created or run afterwards (a
/// benchmarking knob; `Auto` restores the default, direct where available).
pub fn set_default_conv_kernel(kernel: ConvKernel) {
    let k = match kernel {
        ConvKernel::Auto => ConvKernel::Direct,
        k => k,
    };
    DEFAULT_KERNEL.store(k as u8, Ordering::Relaxed);
}

/// Whether the direct kernels run for scalar type `T` and kernel side `k` on this CPU.
pub fn direct_conv_available<T: Float>(k: usize) -> bool {
    direct::kernels::<T>(k).is_some()
}

/// Stride-1 "same" 2-D cross-correlation with an odd square kernel, optionally followed by
/// ReLU (see the module docs). Forward keeps the padded input for backward.
pub struct Conv2d {
    /// What the kernel reads outside the image.
    pub padding: Padding,
    /// Apply `max(·, 0)` to the output (op name `"conv2d_relu"`).
    pub relu: bool,
    /// Implementation to run.
    pub kernel: ConvKernel,
    /// The padded input of the last forward (a `SavedPad<T>`), reused by backward.
    saved: Option<Box<dyn Any + Send + Sync>>,
}

/// Padded copies of every image of the input at `x_addr` (compared in backward, so a backward
/// run with substituted inputs pads afresh), in the layout of the path that wrote them.
struct SavedPad<T: Float> {
    x_addr: usize,
    direct: bool,
    buf: Scratch<T>,
}

impl Conv2d {
    /// The op with [`ConvKernel::Auto`]; see [`Tape::conv2d`] and [`Tape::conv2d_relu`].
    pub fn new(padding: Padding, relu: bool) -> Self {
        Conv2d {
            padding,
            relu,
            kernel: ConvKernel::Auto,
            saved: None,
        }
    }

    /// The same op running `kernel`.
    pub fn with_kernel(mut self, kernel: ConvKernel) -> Self {
        self.kernel = kernel;
        self
    }

    /// The direct kernels, when this op should and can use them.
    fn direct<T: Float>(&self, k: usize) -> Option<&'static direct::Table<T>> {
        let choice = match self.kernel {
            ConvKernel::Auto
                if DEFAULT_KERNEL.load(Ordering::Relaxed) == ConvKernel::Gemm as u8 =>
            {
                ConvKernel::Gemm
            }
            k => k,
        };
        match choice {
            ConvKernel::Gemm => None,
            ConvKernel::Auto | ConvKernel::Direct => direct::kernels::<T>(k),
        }
    }
}

impl std::fmt::Debug for Conv2d {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Conv2d")
            .field("padding", &self.padding)
            .field("relu", &self.relu)
            .field("kernel", &self.kernel)
            .finish()
    }
}

impl Conv2d {
    fn geometry<T: Float>(&self, x: &Tensor<T>, w: &Tensor<T>) -> (usize, usize, Geometry) {
        let (b, c, h, wd) = x.shape().bchw("conv2d");
        let (co, ci, k, k2) = w.shape().bchw("conv2d weight");
        (
            b,
            co,
            Geometry {
                c: ci.max(c),
                h,
                w: wd,
                k: k.max(k2),
                mode: self.padding,
            },
        )
    }
}

#[track_caller]
fn check_conv_shapes(x: Shape, w: Shape, padding: Padding) {
    let (_, c, h, wd) = x.bchw("conv2d");
    let (_, ci, k, k2) = w.bchw("conv2d weight");
    assert!(
        ci == c && k == k2 && k % 2 == 1,
        "conv2d: input {x:?} and weight {w:?} do not fit (want weight (Cout, {c}, k, k), k odd)"
    );
    if padding == Padding::Reflect {
        assert!(
            k / 2 < h && k / 2 < wd,
            "conv2d: reflect padding {} needs an image larger than that, input {x:?}, weight {w:?}",
            k / 2
        );
    }
}

impl<T: Float> Op<T> for Conv2d {
    fn name(&self) -> &'static str {
        if self.relu {
            "conv2d_relu"
        } else {
            "conv2d"
        }
    }

    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        assert_eq!(inputs.len(), 2, "conv2d: takes (x, w)");
        check_conv_shapes(inputs[0].shape(), inputs[1].shape(), self.padding);
        let (b, _, h, w) = inputs[0].shape().bchw("conv2d");
        Shape::new(&[b, inputs[1].dims()[0], h, w])
    }

    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let (x, w) = (inputs[0], inputs[1]);
        let (batch, co, g) = self.geometry(x, w);
        let x_addr = x.data().as_ptr() as usize;
        self.saved = None;
        let buf = match self.direct::<T>(g.k) {
            Some(table) => {
                let keep = direct::keeps_padded(&g, co, batch);
                let mut xp = Scratch::<T>::take(if keep {
                    batch * direct::xp_stride(&g)
                } else {
                    0
                });
                (table.forward)(direct::FwdArgs {
                    g,
                    co,
                    x: x.data(),
                    w: w.data(),
                    y: out.data_mut(),
                    relu: self.relu,
                    xp: keep.then_some(&mut xp[..]),
                });
                keep.then_some((xp, true))
            }
            None => gemm_path::forward(g, batch, co, x, w, out, self.relu).map(|b| (b, false)),
        };
        if let Some((buf, direct)) = buf {
            self.saved = Some(Box::new(SavedPad {
                x_addr,
                direct,
                buf,
            }));
        }
    }

    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let (x, w) = (cx.inputs[0], cx.inputs[1]);
        let (batch, co, g) = self.geometry(x, w);
        let table = self.direct::<T>(g.k);
        let saved = self
            .saved
            .as_ref()
            .and_then(|b| b.downcast_ref::<SavedPad<T>>())
            .filter(|s| s.x_addr == x.data().as_ptr() as usize && s.direct == table.is_some())
            .map(|s| &*s.buf);
        let Some(table) = table else {
            gemm_path::backward(g, batch, co, self.relu, cx, dx, saved);
            return;
        };
        let want_w = dx.wants(1);
        // ∂w into a zeroed scratch first: both slots borrow `dx`.
        let mut gw = Scratch::<T>::zeroed(if want_w { w.data().len() } else { 0 });
        let (gx, gx_add) = match dx.target(0).map(GradTarget::into_parts) {
            Some((g, add)) => (Some(g), add),
            None => (None, true),
        };
        (table.backward)(direct::BwdArgs {
            g,
            co,
            x: x.data(),
            w: w.data(),
            dy: cx.dy.data(),
            mask: self.relu.then(|| cx.output.data()),
            xp: saved,
            gx,
            gx_add,
            gw: want_w.then_some(&mut gw[..]),
        });
        if let Some(slot) = dx.target(1) {
            slot.write(&gw);
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
    /// Stride-1 "same" convolution (cross-correlation) of `x (B, Cin, H, W)` with
    /// `w (Cout, Cin, k, k)`, `k` odd, no bias → `(B, Cout, H, W)`. See [`Conv2d`].
    #[track_caller]
    pub fn conv2d(&mut self, x: Var, w: Var, padding: Padding) -> Var {
        self.apply(Conv2d::new(padding, false), &[x, w])
    }

    /// `relu(conv2d(x, w, padding))` as one op: same shapes as [`Tape::conv2d`], no extra
    /// pass for the ReLU in forward or backward. See [`Conv2d`].
    #[track_caller]
    pub fn conv2d_relu(&mut self, x: Var, w: Var, padding: Padding) -> Var {
        self.apply(Conv2d::new(padding, true), &[x, w])
    }

    /// Transposed convolution, kernel 2, stride 2: `x (B, Cin, H, W)`, `w (Cin, Cout, 2, 2)` →
    /// `(B, Cout, 2H, 2W)`, no bias. See [`ConvTranspose2x2`].
    #[track_caller]
    pub fn conv_transpose2x2(&mut self, x: Var, w: Var) -> Var {
        self.apply(ConvTranspose2x2, &[x, w])
    }
}

#[cfg(test)]
mod tests;
