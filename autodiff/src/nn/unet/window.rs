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
mod tests {
    use super::super::{UNet, UNetConfig};
    use super::OutputBox;
    use crate::{ParamStore, Tape, Tensor};

    fn net(widths: Vec<usize>) -> (UNet, ParamStore<f32>) {
        let mut ps = ParamStore::<f32>::new();
        let cfg = UNetConfig {
            in_channels: 2,
            out_channels: 3,
            widths,
            seed: 7,
        };
        (UNet::new(&mut ps, "u", cfg), ps)
    }

    /// The output `(C, H, W)` of one image `(2, h, w)`.
    fn run(net: &UNet, ps: &ParamStore<f32>, x: &[f32], h: usize, w: usize) -> Vec<f32> {
        let mut tape = Tape::<f32>::new();
        let v = tape.constant_from([1, 2, h, w], x);
        let y = net.forward(&mut tape, ps, v);
        tape.value(y).data().to_vec()
    }

    fn image(h: usize, w: usize, seed: u32) -> Vec<f32> {
        Tensor::<f32>::from_fn([2, h, w], |i| {
            let k = (i as u32).wrapping_mul(2_654_435_761).wrapping_add(seed);
            (k % 1000) as f32 / 500.0 - 1.0
        })
        .data()
        .to_vec()
    }

    #[test]
    fn reach_of_the_official_depths() {
        // Worked by hand from the module docs' rules, level by level.
        let (n2, _) = net(vec![4, 8]);
        assert_eq!(n2.alignment_px(), 2);
        assert_eq!(n2.input_interval([10, 10]), [2, 19]);
        let (n4, _) = net(vec![4, 8, 16, 32]);
        assert_eq!(n4.alignment_px(), 8);
        assert_eq!(n4.input_interval([40, 40]), [-6, 85]);
        assert_eq!(n4.exact_window([40, 40], 256), [0, 88]);
        assert_eq!(n4.exact_window([100, 130], 256), [48, 184]);
    }

    #[test]
    fn the_longest_window_is_the_longest_over_every_start() {
        for widths in [
            vec![4],
            vec![4, 8],
            vec![4, 8, 16, 32],
            vec![4, 8, 16, 32, 64],
        ] {
            let (unet, _) = net(widths.clone());
            let config = UNetConfig {
                in_channels: 2,
                out_channels: 3,
                widths,
                seed: 7,
            };
            for (len, size) in [(1, 256), (31, 256), (40, 64), (200, 256), (64, 64)] {
                // Every start in the field, clamped as a real window is.
                let longest = (0..=size - len)
                    .map(|a| {
                        let [s, e] = unet.exact_window([a, a + len - 1], size);
                        e - s
                    })
                    .max()
                    .unwrap();
                let got = config.longest_exact_window(len, size);
                assert!(got >= longest, "{len} of {size}: {got} < {longest}");
                // Unclamped, in a field large enough, the longest start is reached.
                let free = (0..64)
                    .map(|a| {
                        let [s, e] = unet.exact_window([512 + a, 512 + a + len - 1], 2048);
                        e - s
                    })
                    .max()
                    .unwrap();
                assert_eq!(got, free.min(size), "{len} of {size}");
            }
        }
    }

    #[test]
    fn a_window_decodes_its_box_as_the_whole_field_does() {
        let (net, ps) = net(vec![4, 8, 16]);
        let n = 64;
        let x = image(n, n, 3);
        let full = run(&net, &ps, &x, n, n);
        // Boxes in the middle, at a corner and at an edge.
        for (rows, cols) in [([26, 33], [20, 29]), ([0, 5], [58, 63]), ([30, 31], [0, 9])] {
            let [r0, r1] = net.exact_window(rows, n);
            let [c0, c1] = net.exact_window(cols, n);
            assert!(
                rows[0] == 0 || c1 - c0 < n,
                "window {c0}..{c1} is the whole field"
            );
            let (h, w) = (r1 - r0, c1 - c0);
            let crop: Vec<f32> = (0..2)
                .flat_map(|c| (r0..r1).flat_map(move |r| (c0..c1).map(move |k| (c, r, k))))
                .map(|(c, r, k)| x[(c * n + r) * n + k])
                .collect();
            let win = run(&net, &ps, &crop, h, w);
            for c in 0..3 {
                for r in rows[0]..=rows[1] {
                    for k in cols[0]..=cols[1] {
                        let a = full[(c * n + r) * n + k];
                        let b = win[(c * h + r - r0) * w + k - c0];
                        assert!(
                            (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                            "box {rows:?}×{cols:?} channel {c} at ({r}, {k}): {a} whole, {b} window"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_boxed_decode_gives_the_whole_inputs_outputs_in_its_box() {
        let nets = [
            vec![4],
            vec![4, 8],
            vec![4, 8, 16],
            vec![4, 8, 16, 32],
            vec![4, 8, 16, 32, 64],
        ];
        for widths in nets {
            let (net, ps) = net(widths);
            let (h, w) = (64, 48);
            let x = image(h, w, 11);
            let full = run(&net, &ps, &x, h, w);
            // Middle, corners, edges, one pixel, a thin strip, near the far corner off the
            // pooling grid, and the whole input.
            for (rows, cols) in [
                ([20, 37], [13, 30]),
                ([0, 5], [42, 47]),
                ([58, 63], [0, 0]),
                ([31, 31], [17, 17]),
                ([1, 62], [23, 24]),
                ([49, 61], [33, 45]),
                ([0, 63], [0, 47]),
            ] {
                let mut tape = Tape::<f32>::new();
                let v = tape.constant_from([1, 2, h, w], &x);
                let out_box = OutputBox { rows, cols };
                let y = net.forward_box(&mut tape, &ps, v, out_box);
                let (bh, bw) = out_box.size();
                assert_eq!(tape.shape(y).dims(), &[1, 3, bh, bw]);
                let boxed = tape.value(y).data();
                for c in 0..3 {
                    for r in 0..bh {
                        for k in 0..bw {
                            let a = full[(c * h + r + rows[0]) * w + k + cols[0]];
                            let b = boxed[(c * bh + r) * bw + k];
                            // The 3×3 convs sum each pixel in one order whatever the region;
                            // the 1×1 output conv is a GEMM, whose order may change with it.
                            assert!(
                                (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                                "{} levels, box {rows:?}×{cols:?}, channel {c} at ({r}, {k}): \
                                 {a} whole, {b} boxed",
                                net.downs.len()
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_up_blocks_regions_of_a_box_in_the_middle_are_worked_by_hand() {
        let (net, _) = net(vec![4, 8, 16, 32]);
        // Level 0: [40, 41] → [38, 43]; level 1: [19, 21] → [17, 23] → [16, 23];
        // level 2: [8, 11] → [6, 13]. A box at the edge is clamped to the image.
        assert_eq!(
            net.up_regions([40, 41], 64),
            vec![[38, 43], [16, 23], [6, 13]]
        );
        assert_eq!(net.up_regions([0, 0], 64), vec![[0, 3], [0, 3], [0, 3]]);
        assert_eq!(
            net.up_regions([63, 63], 64),
            vec![[60, 63], [28, 31], [12, 15]]
        );
    }

    fn decode_box(rows: [usize; 2], cols: [usize; 2]) {
        let (net, ps) = net(vec![4, 8]);
        let mut tape = Tape::<f32>::new();
        let v = tape.constant_from([1, 2, 8, 8], &image(8, 8, 1));
        net.forward_box(&mut tape, &ps, v, OutputBox { rows, cols });
    }

    #[test]
    #[should_panic(expected = "UNet::forward_box")]
    fn a_box_past_its_input_is_refused() {
        decode_box([2, 8], [0, 1]);
    }

    #[test]
    #[should_panic(expected = "UNet::forward_box")]
    fn a_reversed_box_is_refused() {
        decode_box([5, 2], [0, 1]);
    }

    #[test]
    fn outside_the_interval_nothing_reaches_the_box_and_at_its_edge_something_does() {
        let (net, ps) = net(vec![4, 8, 16]);
        let n = 64;
        let x = image(n, n, 5);
        let full = run(&net, &ps, &x, n, n);
        let rows = [30usize, 32];
        let [lo, hi] = net.input_interval([30, 32]);
        let changed = |row: i64| {
            let mut y = x.clone();
            for c in 0..2 {
                for k in 0..n {
                    y[(c * n + row as usize) * n + k] += 5.0;
                }
            }
            let out = run(&net, &ps, &y, n, n);
            (0..3).any(|c| {
                (rows[0]..=rows[1])
                    .any(|r| (0..n).any(|k| out[(c * n + r) * n + k] != full[(c * n + r) * n + k]))
            })
        };
        assert!(
            !changed(lo - 1) && !changed(hi + 1),
            "rows outside [{lo}, {hi}] reach the box"
        );
        assert!(
            changed(lo) && changed(hi),
            "the interval [{lo}, {hi}] is wider than the reach"
        );
    }
}
