//! Zero-padding into a larger grid and cropping a window, over the **last two axes** of a real
//! tensor `(…, H, W)` (any leading axes, rank ≥ 2).
//!
//! Linear convolution by FFT needs the image on a grid at least `image + kernel − 1` wide
//! (`2n − 1` for a kernel as large as the image, authors' code, docs/references.md#w-bucket): pad, transform, multiply,
//! transform back, crop. The two ops are adjoint: the backward of `pad2d` crops the gradient and
//! the backward of `crop2d` pads it.

use crate::op::{BackwardCx, GradSlots, Op};
use crate::{Float, Shape, Tape, Tensor, Var};

/// A plane size `(H, W)` and a window offset `(top, left)` in it.
type Window = ((usize, usize), (usize, usize));

/// For every leading index (plane), adds (`add`) or copies the `size` window at `src_at` of a
/// `src_hw` plane of `src` into the window at `dst_at` of a `dst_hw` plane of `dst`.
fn blit<T: Float>(
    src: &[T],
    (src_hw, src_at): Window,
    dst: &mut [T],
    (dst_hw, dst_at): Window,
    (h, w): (usize, usize),
    add: bool,
) {
    let (src_plane, dst_plane) = (src_hw.0 * src_hw.1, dst_hw.0 * dst_hw.1);
    if h * w == 0 || src_plane == 0 {
        return;
    }
    for p in 0..src.len() / src_plane {
        for y in 0..h {
            let s = &src[p * src_plane + (src_at.0 + y) * src_hw.1 + src_at.1..][..w];
            let d = &mut dst[p * dst_plane + (dst_at.0 + y) * dst_hw.1 + dst_at.1..][..w];
            if add {
                d.iter_mut().zip(s).for_each(|(d, &s)| *d += s);
            } else {
                d.copy_from_slice(s);
            }
        }
    }
}

/// The `(H, W)` of the last two axes; panics naming `op` for rank < 2.
#[track_caller]
fn last2(op: &str, s: Shape) -> (usize, usize) {
    let d = s.dims();
    assert!(d.len() >= 2, "{op}: expected a tensor (…, H, W), got {s:?}");
    (d[d.len() - 2], d[d.len() - 1])
}

/// `pad = true`: small input placed in a zero grid `out_hw` at `at`. `false`: crop `out_hw` at `at`.
struct PadCrop {
    pad: bool,
    at: (usize, usize),
    out_hw: (usize, usize),
}

impl PadCrop {
    /// `((plane, offset) of the input, (plane, offset) of the output)`.
    fn windows(&self, in_hw: (usize, usize)) -> (Window, Window) {
        if self.pad {
            ((in_hw, (0, 0)), (self.out_hw, self.at))
        } else {
            ((in_hw, self.at), (self.out_hw, (0, 0)))
        }
    }

    /// The size of the copied window: the smaller grid.
    fn size(&self, in_hw: (usize, usize)) -> (usize, usize) {
        if self.pad {
            in_hw
        } else {
            self.out_hw
        }
    }

    fn op(&self) -> &'static str {
        if self.pad {
            "pad2d"
        } else {
            "crop2d"
        }
    }
}

impl<T: Float> Op<T> for PadCrop {
    fn name(&self) -> &'static str {
        self.op()
    }
    fn output_shape(&self, inputs: &[&Tensor<T>]) -> Shape {
        let s = inputs[0].shape();
        let (h, w) = last2(self.op(), s);
        let ((top, left), (oh, ow)) = (self.at, self.out_hw);
        let (small, big) = if self.pad {
            ((h, w), (oh, ow))
        } else {
            ((oh, ow), (h, w))
        };
        assert!(
            top + small.0 <= big.0 && left + small.1 <= big.1,
            "{}: a {}×{} window at (top {top}, left {left}) does not fit a {}×{} grid (input {s:?})",
            self.op(),
            small.0,
            small.1,
            big.0,
            big.1
        );
        let mut d = s.dims().to_vec();
        let r = d.len();
        d[r - 2] = oh;
        d[r - 1] = ow;
        Shape::new(&d)
    }
    fn forward(&mut self, inputs: &[&Tensor<T>], out: &mut Tensor<T>) {
        let in_hw = last2(self.op(), inputs[0].shape());
        let (src, dst) = self.windows(in_hw);
        blit(
            inputs[0].data(),
            src,
            out.data_mut(),
            dst,
            self.size(in_hw),
            false,
        );
    }
    fn backward(&self, cx: &BackwardCx<'_, T>, dx: &mut GradSlots<'_, T>) {
        let in_hw = last2(self.op(), cx.inputs[0].shape());
        let (src, dst) = self.windows(in_hw);
        if let Some(g) = dx.slot_data(0) {
            blit(cx.dy.data(), dst, g, src, self.size(in_hw), true);
        }
    }
}

impl<T: Float> Tape<T> {
    /// Zero-pads the last two axes `(H, W)` into an `out_h × out_w` grid with the input's
    /// top-left corner at `(top, left)`. Panics when the input does not fit.
    #[track_caller]
    pub fn pad2d(&mut self, x: Var, top: usize, left: usize, out_h: usize, out_w: usize) -> Var {
        self.apply(
            PadCrop {
                pad: true,
                at: (top, left),
                out_hw: (out_h, out_w),
            },
            &[x],
        )
    }

    /// The `h × w` window of the last two axes whose top-left corner is at `(top, left)`.
    /// Panics when the window does not fit.
    #[track_caller]
    pub fn crop2d(&mut self, x: Var, top: usize, left: usize, h: usize, w: usize) -> Var {
        self.apply(
            PadCrop {
                pad: false,
                at: (top, left),
                out_hw: (h, w),
            },
            &[x],
        )
    }
}
