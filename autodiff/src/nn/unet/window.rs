//! Which input pixels a U-Net output pixel depends on, and the smallest window of a large field
//! on which the network computes a box of outputs exactly as on the whole field. A caller that
//! needs a few hundred outputs of a 256 × 256 field (CMF-SIM reads the cones one patch covers)
//! decodes that window alone.
//!
//! Conventions: an interval is inclusive, `[first, last]`, in pixels along one axis at the
//! input's resolution; rows and columns are independent (every op reaches along each axis on its
//! own). From an output interval `[a, b]` back to the input of each op:
//! - 3×3 conv with reflect padding: `[a − 1, b + 1]` (a reflection only reads pixels inside);
//! - 2×2 max pool: `[2a, 2b + 1]`;
//! - 2×2 stride-2 transposed conv: `[⌊a/2⌋, ⌊b/2⌋]`;
//! - 1×1 conv: `[a, b]`; a concatenation needs the union of its inputs' reaches.
//!
//! The interval may reach past the image; the window is clamped to the image. A window decoded
//! on its own must start and end on the pooling grid (multiples of [`UNet::alignment_px`]), or at
//! the field's edges, where the window's reflect padding is the field's: then every pixel inside
//! the returned interval sees exactly the values it sees in the whole field.
//!
//! Inside a window, the encoder must run on all of it (the deepest level reaches furthest), but
//! the decoder need not: [`UNet::forward_box`] runs each up block on the region its part of an
//! [`OutputBox`] reaches. Going up from the box at level 0, an up block's outputs `[a, b]` need
//! its concatenated input on `[a − 2, b + 2]` (two 3×3 convs), clamped to the image and widened
//! to `[2⌊·/2⌋, 2⌊·/2⌋ + 1]` so that the transposed conv fills it from the level below's
//! `[⌊a′/2⌋, ⌊b′/2⌋]`, which is that block's outputs. The skip is cut to the same region. The
//! up block's reflect padding at a cut inside the image makes wrong values within two pixels of
//! it, which no output of the box reads; at the image's edge it is the image's own. So the box
//! holds the same arithmetic on the same values as the whole input's output there, up to the
//! order in which a matrix product sums: the direct 3×3 kernels sum each pixel in one order
//! whatever the region, but the 1×1 output conv (and any conv on the GEMM lowering) is a
//! matrix product whose order may change with the region's size, in the last bit.

use super::{UNet, UNetConfig};
use crate::{Float, Tape, Var};

/// Output pixels asked of a decode: rows × columns, inclusive, at the input's resolution.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct OutputBox {
    pub rows: [usize; 2],
    pub cols: [usize; 2],
}

impl OutputBox {
    /// `(rows, columns)` in the box.
    pub fn size(&self) -> (usize, usize) {
        (len(self.rows), len(self.cols))
    }

    /// `x (…, H, W)` cut to the box (`x` itself when the box is all of it).
    pub fn crop<T: Float>(&self, tape: &mut Tape<T>, x: Var) -> Var {
        let (h, w) = self.size();
        cut(tape, x, [self.rows[0], self.cols[0]], h, w)
    }
}

/// Where a boxed decode runs each up block: per level (0: the shallowest), the rows and
/// columns (inclusive, at that level's resolution) of the block's input and output.
pub(super) struct UpCrops {
    rows: Vec<[usize; 2]>,
    cols: Vec<[usize; 2]>,
    out_box: OutputBox,
}

impl UpCrops {
    /// Cuts the inputs of the up block at `level`: `lower` (the level below's output: the
    /// bottleneck, whole, or that up block's region) to what the transposed conv needs, and
    /// `skip` (the encoder's whole output at `level`) to the block's region.
    pub(super) fn cut_inputs<T: Float>(
        &self,
        tape: &mut Tape<T>,
        level: usize,
        lower: Var,
        skip: Var,
    ) -> (Var, Var) {
        let (r, c) = (self.rows[level], self.cols[level]);
        let (r0, c0) = match self.rows.get(level + 1) {
            Some(lr) => (lr[0], self.cols[level + 1][0]),
            None => (0, 0),
        };
        let lower = cut(
            tape,
            lower,
            [r[0] / 2 - r0, c[0] / 2 - c0],
            len(r) / 2,
            len(c) / 2,
        );
        let skip = cut(tape, skip, [r[0], c[0]], len(r), len(c));
        (lower, skip)
    }

    /// Cuts the last up block's output (its region at level 0; the whole input when the net
    /// has no pooling level, hence no up block) to the box.
    pub(super) fn cut_output<T: Float>(&self, tape: &mut Tape<T>, h: Var) -> Var {
        let b = self.out_box;
        let (r0, c0) = self
            .rows
            .first()
            .zip(self.cols.first())
            .map_or((0, 0), |(r, c)| (r[0], c[0]));
        let local = OutputBox {
            rows: [b.rows[0] - r0, b.rows[1] - r0],
            cols: [b.cols[0] - c0, b.cols[1] - c0],
        };
        local.crop(tape, h)
    }
}

fn len(iv: [usize; 2]) -> usize {
    iv[1] - iv[0] + 1
}

/// `x`'s `h × w` window at `at`, or `x` itself when that is all of it.
fn cut<T: Float>(tape: &mut Tape<T>, x: Var, at: [usize; 2], h: usize, w: usize) -> Var {
    let (_, _, xh, xw) = tape.shape(x).bchw("UNet box");
    if at == [0, 0] && (h, w) == (xh, xw) {
        x
    } else {
        tape.crop2d(x, at[0], at[1], h, w)
    }
}

/// `[a − r, b + r]`.
fn widen(iv: [i64; 2], r: i64) -> [i64; 2] {
    [iv[0] - r, iv[1] + r]
}

/// The smallest interval holding both.
fn union(a: [i64; 2], b: [i64; 2]) -> [i64; 2] {
    [a[0].min(b[0]), a[1].max(b[1])]
}

impl UNetConfig {
    /// Pooling levels: `widths.len() − 1`.
    fn levels(&self) -> usize {
        self.widths.len().saturating_sub(1)
    }

    /// The pooling factor `2^(levels − 1)`: input sides and window offsets must be multiples of it.
    pub fn alignment_px(&self) -> usize {
        1 << self.levels()
    }

    /// The input interval (one axis, inclusive) that the output pixels `[a, b]` depend on
    /// (module docs; unclamped). A property of the shapes alone: no weight is read.
    pub fn input_interval(&self, output: [i64; 2]) -> [i64; 2] {
        assert!(
            output[0] <= output[1],
            "UNet::input_interval: empty interval {output:?}"
        );
        // The 1×1 output conv reaches no further than the last decoder block's output.
        self.decoder_reach(0, output)
    }

    /// The window `[start, end)` of a field of `size_px` pixels (one axis) on which the network
    /// computes the outputs `[a, b]` exactly as on the whole field: the input interval widened to
    /// the pooling grid and clamped to the field.
    #[track_caller]
    pub fn exact_window(&self, output: [usize; 2], size_px: usize) -> [usize; 2] {
        let m = self.alignment_px();
        assert!(
            size_px.is_multiple_of(m) && output[1] < size_px,
            "UNet::exact_window: outputs {output:?} of a field of {size_px} (a multiple of {m})"
        );
        let [lo, hi] = self.input_interval([output[0] as i64, output[1] as i64]);
        let m = m as i64;
        let start = lo.div_euclid(m) * m;
        let end = (hi + 1 + m - 1).div_euclid(m) * m;
        [start.max(0) as usize, (end as usize).min(size_px)]
    }

    /// The longest [`UNetConfig::exact_window`] of `len_px` consecutive outputs of a field of
    /// `size_px` pixels, wherever they start (the pooling grid makes it depend on the start):
    /// what a memory estimate counts for a decode of that many outputs.
    pub fn longest_exact_window(&self, len_px: usize, size_px: usize) -> usize {
        let (m, len) = (self.alignment_px(), len_px.max(1));
        // Far enough from a field's edges that no window is clamped.
        let [lo, hi] = self.input_interval([0, len as i64 - 1]);
        let base = ((hi - lo) as usize + len).next_multiple_of(m);
        (base..base + m)
            .map(|a| {
                let [s, e] = self.exact_window([a, a + len - 1], 3 * base);
                e - s
            })
            .max()
            .unwrap_or(size_px)
            .min(size_px)
    }

    /// What the encoder's block at `level` (0: `inc`) needs of the input for its outputs `iv`.
    fn encoder_reach(&self, level: usize, iv: [i64; 2]) -> [i64; 2] {
        let iv = widen(iv, 2); // DoubleConv: two 3×3 convs.
        if level == 0 {
            iv
        } else {
            self.encoder_reach(level - 1, [2 * iv[0], 2 * iv[1] + 1]) // 2×2 max pool
        }
    }

    /// What the decoder's output at `level` (the bottleneck at the deepest level) needs of the
    /// input for its outputs `iv`.
    fn decoder_reach(&self, level: usize, iv: [i64; 2]) -> [i64; 2] {
        if level == self.levels() {
            return self.encoder_reach(level, iv);
        }
        let cat = widen(iv, 2); // the up block's DoubleConv over [skip, up]
        let skip = self.encoder_reach(level, cat);
        let up = self.decoder_reach(level + 1, [cat[0].div_euclid(2), cat[1].div_euclid(2)]);
        union(skip, up)
    }
}

impl UNet {
    /// [`UNetConfig::alignment_px`] of this net.
    pub fn alignment_px(&self) -> usize {
        self.config.alignment_px()
    }

    /// [`UNetConfig::input_interval`] of this net.
    pub fn input_interval(&self, output: [i64; 2]) -> [i64; 2] {
        self.config.input_interval(output)
    }

    /// [`UNetConfig::exact_window`] of this net.
    #[track_caller]
    pub fn exact_window(&self, output: [usize; 2], size_px: usize) -> [usize; 2] {
        self.config.exact_window(output, size_px)
    }

    /// The up blocks' regions (module docs) for the outputs `out_box` of an `h × w` input.
    #[track_caller]
    pub(super) fn up_crops(&self, out_box: OutputBox, h: usize, w: usize) -> UpCrops {
        assert!(
            out_box.rows[0] <= out_box.rows[1]
                && out_box.rows[1] < h
                && out_box.cols[0] <= out_box.cols[1]
                && out_box.cols[1] < w,
            "UNet::forward_box: {out_box:?} of a {h} × {w} input"
        );
        UpCrops {
            rows: self.up_regions(out_box.rows, h),
            cols: self.up_regions(out_box.cols, w),
            out_box,
        }
    }

    /// One axis of [`UNet::up_crops`]: each up block's region, shallowest first, for the
    /// outputs `out` of an axis of `size_px`.
    fn up_regions(&self, out: [usize; 2], size_px: usize) -> Vec<[usize; 2]> {
        let (mut iv, mut size) = (out, size_px);
        let mut regions = Vec::with_capacity(self.downs.len());
        for _ in 0..self.downs.len() {
            let (lo, hi) = (iv[0].saturating_sub(2), (iv[1] + 2).min(size - 1));
            let region = [lo / 2 * 2, hi / 2 * 2 + 1];
            regions.push(region);
            iv = [region[0] / 2, region[1] / 2];
            size /= 2;
        }
        regions
    }
}

#[cfg(test)]
mod tests;
