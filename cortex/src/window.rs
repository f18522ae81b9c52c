//! Decode Φ on a window of the field, for evaluations that read a few cells of each frame
//! (CMF-SIM reads the cells one patch covers, a fraction of a 256 × 256 field).
//!
//! W's inverse is a Fourier filter of the whole field and C a per-cell product, both cheap; D,
//! the U-Net, is the cost. So W and C run over the whole field as in [`Cortex::record_decode`],
//! and D runs on one window per frame, cut from `X = pa·C`. A window from
//! [`Cortex::exact_window`] holds everything D's outputs on the cells asked for depend on, on
//! D's pooling grid (`autodiff::nn::unet` window docs), so the percept there is the
//! whole-field percept: the same arithmetic on the same values, up to the order in which a
//! matrix product sums.
//!
//! Conventions: cells are `(row, column)` of the `n × n` ONS grid, row-major; a [`Window`] is
//! rows `top .. top + height` and columns `left .. left + width`. The windows are cut out as
//! constants: evaluation only, no gradient reaches W or C through them.

use crate::buckets::d::DBucket;
use crate::model::{enter, Bucket};
use crate::Cortex;
use autodiff::{Tape, Var};

/// A window of the ONS grid (module docs), in cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Window {
    pub top: usize,
    pub left: usize,
    pub height: usize,
    pub width: usize,
}

impl Window {
    /// The index of grid cell `cell` (row-major in the `n × n` grid) inside the window
    /// (row-major in it), `None` outside.
    pub fn local_index(&self, cell: usize, n: usize) -> Option<usize> {
        let (r, c) = (cell / n, cell % n);
        let inside = (self.top..self.top + self.height).contains(&r)
            && (self.left..self.left + self.width).contains(&c);
        inside.then(|| (r - self.top) * self.width + c - self.left)
    }

    /// The window of `height × width` (at least this one's, on the same pooling grid) that
    /// holds this one, shifted inside the `n × n` grid where it would cross its far edge; it is
    /// exact wherever this one is. Frames decoded in one batch share a size.
    #[track_caller]
    pub fn grown_to(&self, height: usize, width: usize, n: usize) -> Window {
        assert!(
            height >= self.height && width >= self.width && height <= n && width <= n,
            "Window::grown_to: {height} × {width} from {self:?} in {n} × {n}"
        );
        Window {
            top: self.top.min(n - height),
            left: self.left.min(n - width),
            height,
            width,
        }
    }
}

impl Cortex {
    /// The smallest window on which [`Cortex::record_decode_windows`] gives the percept at every
    /// cell of rows `rows` × columns `cols` (inclusive, cells) as decode Φ of the whole field
    /// does.
    #[track_caller]
    pub fn exact_window(&self, rows: [usize; 2], cols: [usize; 2]) -> Window {
        let n = self.n();
        assert!(
            rows[0] <= rows[1] && rows[1] < n && cols[0] <= cols[1] && cols[1] < n,
            "Cortex::exact_window: rows {rows:?}, columns {cols:?} of a {n} × {n} grid"
        );
        let (r, c) = match &self.d {
            DBucket::UNet(net) => (net.exact_window(rows, n), net.exact_window(cols, n)),
            DBucket::Identity => ([rows[0], rows[1] + 1], [cols[0], cols[1] + 1]),
        };
        Window {
            top: r[0],
            left: c[0],
            height: r[1] - r[0],
            width: c[1] - c[0],
        }
    }

    /// Records decode Φ of `ons (B, 1, n, n)` with D on frame b's window `windows[b]` alone
    /// (all of one size `h × w`): the percept `(B, N, h, w)` (module docs; evaluation only).
    #[track_caller]
    pub fn record_decode_windows(&self, tape: &mut Tape<f32>, ons: Var, windows: &[Window]) -> Var {
        let n = self.n();
        let shape = tape.shape(ons);
        let (b, _, _, _) = shape.bchw("Cortex::record_decode_windows");
        let (h, w) = windows
            .first()
            .map(|v| (v.height, v.width))
            .expect("Cortex::record_decode_windows: no windows");
        assert!(
            windows.len() == b
                && windows
                    .iter()
                    .all(|v| (v.height, v.width) == (h, w) && v.top + h <= n && v.left + w <= n),
            "Cortex::record_decode_windows: {} windows of one size inside {n} × {n} for {b} frames",
            windows.len()
        );
        let (x, d_follows) = self.record_injected(tape, ons);
        let ch = tape.shape(x).dims()[1];
        let whole = tape.value(x).data();
        let mut cut = vec![0f32; b * ch * h * w];
        for (f, (v, out)) in windows
            .iter()
            .zip(cut.chunks_exact_mut(ch * h * w))
            .enumerate()
        {
            for (c, out) in out.chunks_exact_mut(h * w).enumerate() {
                let plane = &whole[(f * ch + c) * n * n..(f * ch + c + 1) * n * n];
                for (r, row) in out.chunks_exact_mut(w).enumerate() {
                    let start = (v.top + r) * n + v.left;
                    row.copy_from_slice(&plane[start..start + w]);
                }
            }
        }
        let xw = tape.constant_from([b, ch, h, w], &cut);
        if !d_follows {
            return xw;
        }
        enter(tape, Bucket::D);
        self.d.forward(tape, &self.params, xw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CortexConfig;

    /// A cortex of the tiny preset with every parameter drawn at random (so W, C and D are far
    /// from their identity initialisation).
    fn scrambled(n: usize, widths: Vec<usize>) -> Cortex {
        let mut cfg = CortexConfig::preset("tiny").expect("tiny preset");
        cfg.ons_size_px = n;
        cfg.d.widths = widths;
        let mut cortex = Cortex::new(cfg).expect("cortex");
        let mut k = 17u32;
        let ids: Vec<_> = cortex.params.ids().collect();
        for id in ids {
            for v in cortex.params.get_mut(id).data_mut() {
                k = k.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *v += ((k >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.2;
            }
        }
        cortex
    }

    #[test]
    fn windows_give_the_whole_field_percept_at_the_cells_asked_for() {
        let n = 64;
        let cortex = scrambled(n, vec![4, 8, 16]);
        let frames = 3;
        let ons: Vec<f32> = (0..frames * n * n)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) % 997) as f32 / 997.0)
            .collect();
        let whole = cortex.decode_frames(&ons, frames);
        let dim = cortex.percept_dim();
        // A box in the middle, one at a corner, one on an edge (one box per frame).
        let boxes = [([28, 35], [20, 27]), ([0, 7], [56, 63]), ([40, 47], [0, 7])];
        let sizes: Vec<Window> = boxes
            .iter()
            .map(|&(r, c)| cortex.exact_window(r, c))
            .collect();
        let (h, w) = (
            sizes.iter().map(|v| v.height).max().unwrap(),
            sizes.iter().map(|v| v.width).max().unwrap(),
        );
        assert!(h < n && w < n, "windows {sizes:?} are the whole field");
        // One size for the batch: each window grown, shifted inside the field.
        let windows: Vec<Window> = sizes.iter().map(|v| v.grown_to(h, w, n)).collect();
        let mut tape = Tape::<f32>::new();
        let o = tape.constant_from([frames, 1, n, n], &ons);
        let v = cortex.record_decode_windows(&mut tape, o, &windows);
        let got = tape.value(v).data();
        for (f, (&(rows, cols), win)) in boxes.iter().zip(&windows).enumerate() {
            for c in 0..dim {
                for r in rows[0]..=rows[1] {
                    for k in cols[0]..=cols[1] {
                        let a = whole[((f * dim + c) * n + r) * n + k];
                        let local = win.local_index(r * n + k, n).expect("inside its window");
                        let b = got[(f * dim + c) * h * w + local];
                        assert!(
                            (a - b).abs() <= 1e-5 * (1.0 + a.abs()),
                            "frame {f} channel {c} cell ({r}, {k}): {a} whole field, {b} window"
                        );
                    }
                }
            }
        }
    }
}
