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
mod tests;
