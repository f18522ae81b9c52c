//! Decode Φ on a window of the field, for evaluations that read a few cells of each frame
//! (CMF-SIM reads the cells one patch covers, a fraction of a 256 × 256 field).
//!
//! W's inverse is a Fourier filter of the whole field and C a per-cell product, both cheap; D,
//! the U-Net, is the cost. So W runs over the whole field as in [`Cortex::record_decode`], and
//! C and D run on one window per frame: the activations `pa` and C are cut to it and
//! multiplied there (`X = pa·C` per cell, the same products as over the field). A window from
//! [`Cortex::exact_window`] holds everything D's outputs on the cells asked for depend on, on
//! D's pooling grid (`autodiff::nn::unet` window docs), so the percept there is the
//! whole-field percept: the same arithmetic on the same values, up to the order in which a
//! matrix product sums. W's inverse is linear: a caller whose frames are weighted sums of a
//! few fixed frames can take their activations once ([`Cortex::activations`]), sum those in
//! the window and decode from there ([`Cortex::record_decode_activation_windows`]). Inside the
//! window, the encoder of D must run on all of it, but its decoder only where the cells read
//! reach: a caller that reads a box of cells asks for it ([`OutputBox`]) and gets the percept
//! there alone.
//!
//! Conventions: cells are `(row, column)` of the `n × n` ONS grid, row-major; a [`Window`] is
//! rows `top .. top + height` and columns `left .. left + width`. The windows are cut out as
//! constants: evaluation only, no gradient reaches W or C through them.

use crate::buckets::d::DBucket;
use crate::config::CortexConfig;
use crate::model::{enter, Bucket};
use crate::Cortex;
use autodiff::nn::unet::OutputBox;
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

    /// Cells in the window.
    pub fn area(&self) -> usize {
        self.height * self.width
    }

    /// Copies this window of the `n × n` plane `plane` (row-major) into `out (height × width)`.
    #[track_caller]
    pub fn cut(&self, plane: &[f32], n: usize, out: &mut [f32]) {
        assert!(
            plane.len() == n * n && out.len() == self.height * self.width,
            "Window::cut: {self:?} of a plane of {} into {}",
            plane.len(),
            out.len()
        );
        for (r, row) in out.chunks_exact_mut(self.width).enumerate() {
            let start = (self.top + r) * n + self.left;
            row.copy_from_slice(&plane[start..start + self.width]);
        }
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

/// The largest `(height, width)` that [`Cortex::exact_window`] gives a box of `rows_len ×
/// cols_len` cells, wherever the box lies on the `n × n` grid, for the cortex `config` describes
/// (from its shapes alone: nothing is allocated). A memory estimate counts a decode so.
pub fn longest_window(
    config: &CortexConfig,
    rows_len: usize,
    cols_len: usize,
    n: usize,
) -> (usize, usize) {
    match DBucket::unet_config(config) {
        None => (rows_len.min(n), cols_len.min(n)),
        Some(unet) => (
            unet.longest_exact_window(rows_len, n),
            unet.longest_exact_window(cols_len, n),
        ),
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
    /// With `out_box` (rows × columns inside each window, the same for every frame), only the
    /// percept in the box, `(B, N, box rows, box columns)`, equal to the window's there: D's
    /// up blocks run only where the box reaches (`autodiff::nn::unet` window docs). A caller
    /// reading a patch's cells asks for their bounding box.
    #[track_caller]
    pub fn record_decode_windows(
        &self,
        tape: &mut Tape<f32>,
        ons: Var,
        windows: &[Window],
        out_box: Option<OutputBox>,
    ) -> Var {
        let n = self.n();
        let (b, _, _, _) = tape.shape(ons).bchw("Cortex::record_decode_windows");
        let (h, w) = self.check_windows(windows, b, "Cortex::record_decode_windows");
        enter(tape, Bucket::W);
        let r = self.w.record(tape, &self.params);
        let pa = self.w.decode(tape, r, ons);
        let whole = tape.value(pa).data();
        let mut cut = vec![0f32; b * h * w];
        for (f, (v, out)) in windows.iter().zip(cut.chunks_exact_mut(h * w)).enumerate() {
            v.cut(&whole[f * n * n..(f + 1) * n * n], n, out);
        }
        self.record_decode_activation_windows(tape, &cut, windows, out_box)
    }

    /// Records decode Φ from cone activations already cut to windows: `pa (B × h × w)`, frame
    /// b's activations `pa = W⁻¹(ons)` on `windows[b]` (all of one size), gives the percept
    /// `(B, N, h, w)` (with `out_box`, `(B, N, box rows, box columns)`) that
    /// [`Cortex::record_decode_windows`] gives from the ONS. W's inverse is
    /// a linear filter, so an observer whose frames are sums of a few fixed ones can take their
    /// activations once ([`Cortex::activations`]) and sum those. `out_box` as there.
    #[track_caller]
    pub fn record_decode_activation_windows(
        &self,
        tape: &mut Tape<f32>,
        pa: &[f32],
        windows: &[Window],
        out_box: Option<OutputBox>,
    ) -> Var {
        let n = self.n();
        let b = windows.len();
        let (h, w) = self.check_windows(windows, b, "Cortex::record_decode_activation_windows");
        assert_eq!(
            pa.len(),
            b * h * w,
            "Cortex::record_decode_activation_windows: {} activations for {b} windows of {h} × {w}",
            pa.len()
        );
        let paw = tape.constant_from([b, 1, h, w], pa);
        let Some(cb) = &self.c else {
            return match out_box {
                Some(o) => o.crop(tape, paw),
                None => paw,
            };
        };
        // X = pa·C per cell: C cut to each frame's window, the same products as over the field.
        enter(tape, Bucket::C);
        let c = cb.record(tape, &self.params);
        let ch = tape.shape(c).dims()[1];
        let whole = tape.value(c).data();
        let mut cut = vec![0f32; b * ch * h * w];
        for (v, out) in windows.iter().zip(cut.chunks_exact_mut(ch * h * w)) {
            for (k, plane) in out.chunks_exact_mut(h * w).enumerate() {
                v.cut(&whole[k * n * n..(k + 1) * n * n], n, plane);
            }
        }
        let cw = tape.constant_from([b, ch, h, w], &cut);
        let x = cb.inject(tape, cw, paw);
        enter(tape, Bucket::D);
        match out_box {
            Some(o) => self.d.forward_box(tape, &self.params, x, o),
            None => self.d.forward(tape, &self.params, x),
        }
    }

    /// Φ_W alone: the cone activations `pa (B × n × n)` of ONS frames `(B × n × n)`.
    pub fn activations(&self, ons: &[f32], batch: usize) -> Vec<f32> {
        let mut tape = Tape::<f32>::new();
        let o = self.constant_frames(&mut tape, ons, batch, "Cortex::activations");
        let r = self.w.record(&mut tape, &self.params);
        let pa = self.w.decode(&mut tape, r, o);
        tape.value(pa).data().to_vec()
    }

    /// The size `(h, w)` of `windows`, checked: `frames` of them, of one size, inside the field.
    #[track_caller]
    fn check_windows(&self, windows: &[Window], frames: usize, caller: &str) -> (usize, usize) {
        let n = self.n();
        let (h, w) = windows
            .first()
            .map(|v| (v.height, v.width))
            .unwrap_or_else(|| panic!("{caller}: no windows"));
        assert!(
            windows.len() == frames
                && windows
                    .iter()
                    .all(|v| (v.height, v.width) == (h, w) && v.top + h <= n && v.left + w <= n),
            "{caller}: {} windows of one size inside {n} × {n} for {frames} frames",
            windows.len()
        );
        (h, w)
    }
}

#[cfg(test)]
mod tests_support {
    use super::*;
    use crate::CortexConfig;

    /// A cortex of the tiny preset with every parameter drawn at random (so W, C and D are far
    /// from their identity initialisation).
    pub(super) fn scrambled(n: usize, widths: Vec<usize>) -> Cortex {
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
}

#[cfg(test)]
mod tests {
    use super::tests_support::scrambled;
    use super::*;

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
        let v = cortex.record_decode_windows(&mut tape, o, &windows, None);
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
    #[test]
    fn the_longest_window_bounds_every_box_and_is_reached() {
        let n = 64;
        for widths in [vec![4, 8, 16], vec![4, 8, 16, 32]] {
            let cortex = scrambled(n, widths);
            for (rows_len, cols_len) in [(8, 8), (5, 13), (40, 2)] {
                let mut seen = (0, 0);
                for top in 0..=n - rows_len {
                    for left in 0..=n - cols_len {
                        let w = cortex
                            .exact_window([top, top + rows_len - 1], [left, left + cols_len - 1]);
                        seen = (seen.0.max(w.height), seen.1.max(w.width));
                    }
                }
                let got = longest_window(&cortex.config, rows_len, cols_len, n);
                assert_eq!(got, seen, "boxes of {rows_len} × {cols_len}");
            }
        }
        let mut identity = CortexConfig::preset("tiny").unwrap();
        identity.d.mode = crate::config::DMode::Identity;
        assert_eq!(longest_window(&identity, 5, 13, 64), (5, 13));
    }

    #[test]
    fn frames_summed_from_activations_decode_as_the_summed_ons_does() {
        let n = 64;
        let cortex = scrambled(n, vec![4, 8, 16]);
        // Three fixed frames and two sums of them with different weights.
        let basis: Vec<f32> = (0..3 * n * n)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) % 991) as f32 / 991.0)
            .collect();
        let weights = [[0.3f32, 1.2, 0.05], [2.0, 0.0, 0.7]];
        let pa_basis = cortex.activations(&basis, 3);
        let window = cortex.exact_window([20, 27], [30, 37]);
        let windows = [window; 2];
        let (h, w) = (window.height, window.width);
        let (mut ons, mut pa) = (vec![0f32; 2 * n * n], vec![0f32; 2 * h * w]);
        let mut cut = vec![0f32; h * w];
        for (f, wts) in weights.iter().enumerate() {
            for (k, &a) in wts.iter().enumerate() {
                let frame = &basis[k * n * n..(k + 1) * n * n];
                for (o, &x) in ons[f * n * n..(f + 1) * n * n].iter_mut().zip(frame) {
                    *o += a * x;
                }
                window.cut(&pa_basis[k * n * n..(k + 1) * n * n], n, &mut cut);
                for (o, &x) in pa[f * h * w..(f + 1) * h * w].iter_mut().zip(&cut) {
                    *o += a * x;
                }
            }
        }
        let mut tape = Tape::<f32>::new();
        let o = tape.constant_from([2, 1, n, n], &ons);
        let from_ons = cortex.record_decode_windows(&mut tape, o, &windows, None);
        let from_ons = tape.value(from_ons).data().to_vec();
        let from_pa = cortex.record_decode_activation_windows(&mut tape, &pa, &windows, None);
        let from_pa = tape.value(from_pa).data();
        assert_eq!(from_ons.len(), from_pa.len());
        let scale = from_ons.iter().fold(0f32, |m, x| m.max(x.abs()));
        for (i, (a, b)) in from_ons.iter().zip(from_pa).enumerate() {
            assert!(
                (a - b).abs() <= 1e-5 * scale,
                "value {i}: {a} from the summed ONS, {b} from summed activations (scale {scale})"
            );
        }
        // and a frame that is not the sum decodes otherwise
        pa.iter_mut().for_each(|x| *x *= 1.5);
        let other = cortex.record_decode_activation_windows(&mut tape, &pa, &windows, None);
        let other = tape.value(other).data();
        assert!(from_ons
            .iter()
            .zip(other)
            .any(|(a, b)| (a - b).abs() > 1e-3 * scale));
    }
}

#[cfg(test)]
mod box_tests {
    use super::tests_support::scrambled;
    use super::*;

    #[test]
    fn a_boxed_decode_gives_the_windows_percept_in_its_box() {
        let n = 64;
        let cortex = scrambled(n, vec![4, 8, 16]);
        let window = cortex.exact_window([20, 27], [30, 37]);
        let windows = [window; 2];
        let (h, w) = (window.height, window.width);
        let pa: Vec<f32> = (0..2 * h * w)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) % 983) as f32 / 983.0)
            .collect();
        let mut tape = Tape::<f32>::new();
        let whole = cortex.record_decode_activation_windows(&mut tape, &pa, &windows, None);
        let whole = tape.value(whole).data().to_vec();
        let dim = cortex.percept_dim();
        // The cells asked for, inside the window; and a box at the window's corner.
        let inside = |r: usize, c: usize| (r - window.top, c - window.left);
        let (r0, c0) = inside(20, 30);
        let (r1, c1) = inside(27, 37);
        for out_box in [
            OutputBox {
                rows: [r0, r1],
                cols: [c0, c1],
            },
            OutputBox {
                rows: [0, 3],
                cols: [w - 5, w - 1],
            },
        ] {
            let v =
                cortex.record_decode_activation_windows(&mut tape, &pa, &windows, Some(out_box));
            let (bh, bw) = out_box.size();
            assert_eq!(tape.shape(v).dims(), &[2, dim, bh, bw]);
            let boxed = tape.value(v).data();
            for (i, &b) in boxed.iter().enumerate() {
                let (plane, r, k) = (i / (bh * bw), i / bw % bh, i % bw);
                let a = whole[(plane * h + r + out_box.rows[0]) * w + k + out_box.cols[0]];
                assert!(
                    (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                    "{out_box:?}: plane {plane} at ({r}, {k}): {a} window, {b} box"
                );
            }
        }
    }
}
