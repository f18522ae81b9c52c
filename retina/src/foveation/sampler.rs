//! Anti-aliased (mip-mapped) sampling of scene planes at the cone positions.
//!
//! Authors' code, docs/references.md#foveation, step 6: per cone, level ℓ = log2(max(row spacing, column spacing)) in
//! field pixels (the last row and column reuse the previous spacing); each level is the scene
//! box-filtered over 2^ℓ pixels; the cone's value blends levels ⌊ℓ⌋ and ⌈ℓ⌉ linearly
//! (trilinear), each sampled bilinearly.
//!
//! Difference from the official code, on purpose: the levels are kept at full resolution (a
//! "stationary" pyramid). Level k is the centred box of width 2^k — separable taps
//! `[½, 1, …, 1, ½] / 2^k` (2^k + 1 taps; level 1 is the binomial [¼, ½, ¼]) with clamped
//! borders. A scene tile is filtered once, and every integer eye shift then samples it exactly
//! as a filtered crop would be sampled — the official pyramid, rebuilt on each shifted crop, has
//! a half-pixel phase that depends on the shift parity. Sampling stays linear in the scene.
//!
//! Shapes: a [`MipStack`] is `(levels, planes, h, w)` f32, row-major. [`ConeSampler`] holds one
//! precomputed tap per cone; `origin = [ox, oy]` (px) is where the field's top-left pixel lies in
//! the stack, so cone c samples the stack at `positions_px[c] + origin`.

use super::layout::ConeLayout;

/// Full-resolution mip levels of a set of planes (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct MipStack {
    /// Number of levels (level 0 = the planes themselves).
    pub levels: usize,
    /// Planes per level.
    pub planes: usize,
    /// Rows.
    pub h: usize,
    /// Columns.
    pub w: usize,
    /// `(levels, planes, h, w)` row-major.
    pub data: Vec<f32>,
}

/// Separable taps of level `k`: centred box of width 2^k.
fn level_taps(k: usize) -> Vec<f32> {
    if k == 0 {
        return vec![1.0];
    }
    let w = 1usize << k;
    let mut t = vec![1.0 / w as f32; w + 1];
    t[0] *= 0.5;
    t[w] *= 0.5;
    t
}

fn filter_rows(src: &[f32], dst: &mut [f32], h: usize, w: usize, taps: &[f32]) {
    let r = (taps.len() / 2) as isize;
    for y in 0..h {
        let row = &src[y * w..(y + 1) * w];
        for x in 0..w {
            let mut acc = 0.0;
            for (k, &t) in taps.iter().enumerate() {
                let xx = (x as isize + k as isize - r).clamp(0, w as isize - 1) as usize;
                acc += t * row[xx];
            }
            dst[y * w + x] = acc;
        }
    }
}

fn filter_cols(src: &[f32], dst: &mut [f32], h: usize, w: usize, taps: &[f32]) {
    let r = (taps.len() / 2) as isize;
    dst.fill(0.0);
    for y in 0..h {
        let out = &mut dst[y * w..(y + 1) * w];
        for (k, &t) in taps.iter().enumerate() {
            let yy = (y as isize + k as isize - r).clamp(0, h as isize - 1) as usize;
            for (o, &s) in out.iter_mut().zip(&src[yy * w..(yy + 1) * w]) {
                *o += t * s;
            }
        }
    }
}

impl MipStack {
    /// Build `levels` levels from `planes`, shaped `(n_planes, h, w)`.
    pub fn compute(planes: &[f32], n_planes: usize, h: usize, w: usize, levels: usize) -> Self {
        assert_eq!(
            planes.len(),
            n_planes * h * w,
            "MipStack::compute: planes have {} values, expected {n_planes}×{h}×{w}",
            planes.len()
        );
        assert!(levels >= 1, "MipStack::compute: need at least one level");
        let hw = h * w;
        let mut data = vec![0.0f32; levels * n_planes * hw];
        data[..n_planes * hw].copy_from_slice(planes);
        let mut tmp = vec![0.0f32; hw];
        for k in 1..levels {
            let taps = level_taps(k);
            for p in 0..n_planes {
                let src = &planes[p * hw..(p + 1) * hw];
                filter_rows(src, &mut tmp, h, w, &taps);
                let off = (k * n_planes + p) * hw;
                filter_cols(&tmp, &mut data[off..off + hw], h, w, &taps);
            }
        }
        MipStack {
            levels,
            planes: n_planes,
            h,
            w,
            data,
        }
    }

    /// Plane `p` of level `k`, `(h, w)`.
    pub fn plane(&self, k: usize, p: usize) -> &[f32] {
        let hw = self.h * self.w;
        let off = (k * self.planes + p) * hw;
        &self.data[off..off + hw]
    }
}

/// One cone's precomputed sampling footprint.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Tap {
    x0: i32,
    y0: i32,
    fx: f32,
    fy: f32,
    level: u8,
    /// Weight of level `level + 1`.
    t: f32,
}

/// Precomputed per-cone sampling taps for a layout (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ConeSampler {
    taps: Vec<Tap>,
    field_px: usize,
    levels_needed: usize,
    /// Mip level ℓ of each cone (row-major `(n, n)`), for pictures and reports.
    pub level: Vec<f32>,
}

impl ConeSampler {
    /// Taps for every cone of `layout`.
    pub fn compute(layout: &ConeLayout) -> ConeSampler {
        let (n, p) = (layout.n, &layout.positions_px);
        let f = layout.field_px;
        let dist = |a: usize, b: usize| (p[a][0] - p[b][0]).hypot(p[a][1] - p[b][1]);
        let mut taps = Vec::with_capacity(n * n);
        let mut level = Vec::with_capacity(n * n);
        let mut levels_needed = 1;
        for i in 0..n {
            for j in 0..n {
                let c = i * n + j;
                let row = if j + 1 < n {
                    dist(c, c + 1)
                } else {
                    dist(c, c - 1)
                };
                let col = if i + 1 < n {
                    dist(c, c + n)
                } else {
                    dist(c, c - n)
                };
                let l = row.max(col).log2().max(0.0);
                let lo = l.floor();
                let t = l - lo;
                levels_needed = levels_needed.max(lo as usize + 1 + usize::from(t > 0.0));
                let (x, y) = (
                    p[c][0].clamp(0.0, f as f32 - 1.0),
                    p[c][1].clamp(0.0, f as f32 - 1.0),
                );
                let split = |v: f32| {
                    let v0 = (v.floor() as i32).min(f as i32 - 2).max(0);
                    (v0, v - v0 as f32)
                };
                let ((x0, fx), (y0, fy)) = (split(x), split(y));
                taps.push(Tap {
                    x0,
                    y0,
                    fx,
                    fy,
                    level: lo as u8,
                    t,
                });
                level.push(l);
            }
        }
        ConeSampler {
            taps,
            field_px: f,
            levels_needed,
            level,
        }
    }

    /// Number of mip levels the layout needs (stacks must have at least this many).
    pub fn levels_needed(&self) -> usize {
        self.levels_needed
    }

    /// Number of cones.
    pub fn n_cones(&self) -> usize {
        self.taps.len()
    }

    #[inline]
    fn check(&self, stack: &MipStack, origin: [i32; 2]) {
        assert!(
            origin[0] >= 0
                && origin[1] >= 0
                && origin[0] as usize + self.field_px <= stack.w
                && origin[1] as usize + self.field_px <= stack.h
                && stack.levels >= self.levels_needed,
            "ConeSampler: field {f}×{f} at origin {origin:?} (levels {}) does not fit stack \
             {}×{} with {} levels",
            self.levels_needed,
            stack.h,
            stack.w,
            stack.levels,
            f = self.field_px
        );
    }

    #[inline]
    fn sample_tap(stack: &MipStack, plane: usize, tap: &Tap, origin: [i32; 2]) -> f32 {
        let w = stack.w;
        let idx = (tap.y0 + origin[1]) as usize * w + (tap.x0 + origin[0]) as usize;
        let bilerp = |k: usize| {
            let d = stack.plane(k, plane);
            let (a, b, c, e) = (d[idx], d[idx + 1], d[idx + w], d[idx + w + 1]);
            // (1 − t)·p + t·q is exact at t = 0 and t = 1 (pixel-aligned cones).
            let (gx, gy) = (1.0 - tap.fx, 1.0 - tap.fy);
            let top = a * gx + b * tap.fx;
            let bottom = c * gx + e * tap.fx;
            top * gy + bottom * tap.fy
        };
        let k = tap.level as usize;
        let v = bilerp(k);
        if tap.t > 0.0 {
            v + tap.t * (bilerp(k + 1) - v)
        } else {
            v
        }
    }

    /// Sample plane `plane` of `stack` at every cone; `out` is `(n·n)`.
    pub fn sample_plane(&self, stack: &MipStack, plane: usize, origin: [i32; 2], out: &mut [f32]) {
        self.check(stack, origin);
        assert_eq!(
            out.len(),
            self.taps.len(),
            "ConeSampler::sample_plane: out length"
        );
        for (o, tap) in out.iter_mut().zip(&self.taps) {
            *o = Self::sample_tap(stack, plane, tap, origin);
        }
    }

    /// Per cone, `Σ_k weights[c·K + k] · plane_k(cone c)` with K = `weights.len() / n_cones`;
    /// planes `0..K` of `stack` are the weight columns (the stack may hold more planes).
    /// Classes with zero weight are skipped. `out` is `(n·n)`.
    pub fn sample_weighted(
        &self,
        stack: &MipStack,
        weights: &[f32],
        origin: [i32; 2],
        out: &mut [f32],
    ) {
        self.check(stack, origin);
        let k = weights.len() / self.taps.len().max(1);
        assert!(
            weights.len() == self.taps.len() * k && k <= stack.planes && k > 0,
            "ConeSampler::sample_weighted: weights {} for {} cones and a stack of {} planes",
            weights.len(),
            self.taps.len(),
            stack.planes
        );
        assert_eq!(
            out.len(),
            self.taps.len(),
            "ConeSampler::sample_weighted: out length"
        );
        for ((o, tap), w) in out.iter_mut().zip(&self.taps).zip(weights.chunks_exact(k)) {
            let mut acc = 0.0;
            for (p, &wp) in w.iter().enumerate() {
                if wp != 0.0 {
                    acc += wp * Self::sample_tap(stack, p, tap, origin);
                }
            }
            *o = acc;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::foveation::{FoveationConfig, LayoutConfig};

    #[test]
    fn identity_layout_samples_pixels_exactly() {
        let (h, w) = (12, 12);
        let planes: Vec<f32> = (0..h * w).map(|i| (i * 7 % 13) as f32).collect();
        let stack = MipStack::compute(&planes, 1, h, w, 1);
        let l = ConeLayout::identity(8);
        let s = ConeSampler::compute(&l);
        assert_eq!(s.levels_needed(), 1);
        let mut out = vec![0.0; 64];
        s.sample_plane(&stack, 0, [3, 2], &mut out);
        for i in 0..8 {
            for j in 0..8 {
                assert_eq!(out[i * 8 + j], planes[(i + 2) * w + j + 3]);
            }
        }
    }

    #[test]
    fn filters_keep_constants_and_ramps_and_remove_alternation() {
        let (h, w) = (40, 40);
        let ramp: Vec<f32> = (0..h * w).map(|i| (i % w) as f32 * 0.5 + 1.0).collect();
        let checker: Vec<f32> = (0..h * w).map(|i| ((i % w + i / w) % 2) as f32).collect();
        let stack = MipStack::compute(&[ramp.clone(), checker].concat(), 2, h, w, 3);
        for k in 0..3 {
            for y in 5..35 {
                for x in 5..35 {
                    assert!((stack.plane(k, 0)[y * w + x] - ramp[y * w + x]).abs() < 1e-5);
                    if k > 0 {
                        assert!((stack.plane(k, 1)[y * w + x] - 0.5).abs() < 1e-6);
                    }
                }
            }
        }
    }

    #[test]
    fn foveated_sampling_is_linear_and_levels_follow_spacing() {
        let l = ConeLayout::compute(
            &LayoutConfig::Foveated(FoveationConfig::default()),
            32,
            64,
            1,
        );
        let s = ConeSampler::compute(&l);
        let lmin = s.level.iter().copied().fold(f32::INFINITY, f32::min);
        let lmax = s.level.iter().copied().fold(0.0f32, f32::max);
        assert!(lmin < lmax && lmax < 2.0, "levels {lmin}–{lmax}");
        let (h, w) = (70, 70);
        let a: Vec<f32> = (0..h * w).map(|i| ((i * 31) % 17) as f32).collect();
        let b: Vec<f32> = (0..h * w).map(|i| ((i * 13) % 7) as f32).collect();
        let ab: Vec<f32> = a.iter().zip(&b).map(|(x, y)| 2.0 * x - 3.0 * y).collect();
        let stack = MipStack::compute(&[a, b, ab].concat(), 3, h, w, s.levels_needed());
        let mut out = vec![vec![0.0; 32 * 32]; 3];
        for (p, o) in out.iter_mut().enumerate() {
            s.sample_plane(&stack, p, [4, 5], o);
        }
        for c in 0..32 * 32 {
            assert!((out[2][c] - (2.0 * out[0][c] - 3.0 * out[1][c])).abs() < 1e-3);
        }
        // Weighted sampling equals the weighted sum of plane samples.
        let weights: Vec<f32> = (0..32 * 32)
            .flat_map(|c| [0.25, 0.75, (c % 2) as f32])
            .collect();
        let mut wout = vec![0.0; 32 * 32];
        s.sample_weighted(&stack, &weights, [4, 5], &mut wout);
        for c in 0..32 * 32 {
            let e = 0.25 * out[0][c] + 0.75 * out[1][c] + (c % 2) as f32 * out[2][c];
            assert!((wout[c] - e).abs() < 1e-3);
        }
    }

    #[test]
    #[should_panic(expected = "does not fit")]
    fn origin_outside_the_stack_panics() {
        let stack = MipStack::compute(&vec![0.0; 100], 1, 10, 10, 1);
        let s = ConeSampler::compute(&ConeLayout::identity(8));
        s.sample_plane(&stack, 0, [3, 0], &mut vec![0.0; 64]);
    }
}
