//! Cone positions: the foveated retinotopic lattice and the identity layout.
//!
//! Stage `ConeLayout::compute(config, n, field_px, seed)`:
//! - output: `positions_px`, row-major `(n·n)` of `[x, y]` in pixels of the `field_px × field_px`
//!   scene field the cones sample (x = column, y = row, pixel centres at integers, 0 … F−1).
//!   Lattice cell (i, j) is row i, column j of every `(n, n)` cone array downstream.
//!
//! Foveated layout (authors' code, docs/references.md#foveation; paper S-02 "Foveation and Cone Positions"):
//! 1. Perlin jitter in lattice-index space (official run-time step 2): two independent fields
//!    (x and y), 6 octaves from resolution 2 with persistence 0.8, generated on a lattice twice
//!    the patch side whose centre is the patch (the official noise lives on the 512 lattice and
//!    the 256 patch is its centre); the outer ring of that noise lattice is zeroed, as in the
//!    official code (it lies outside the patch; with `JITTER_LATTICE_OVERSIZE = 1` it is the
//!    patch's own ring). Std ≈ 0.5 cell; neighbouring differences are ≪ 1 cell, so cells keep
//!    their orientation.
//! 2. The jittered lattice coordinates go through the area-preserving radial map of
//!    [`super::density`] (Curcio-like density falling from the centre).
//! 3. Positions are rescaled with one min and one max over both coordinates so that they span
//!    the field, `[0, F−1]` (official step 3 rescales to [−1, 1]; `align_corners` sampling makes
//!    −1 and 1 the first and last pixel centres).
//!
//! The edge eccentricity default, 1.25°, is fitted so that the paper layout (256² cones in a
//! 512-px field) has the official centre-to-edge spacing ratio ≈ 1.9 (authors' code, docs/references.md#foveation, step 5:
//! ≈1.3 px at the centre, ≈2.5 px at the patch edge), with spacing = mean distance to the 4
//! lattice neighbours, "centre" = the central 4×4 cells and "edge" = the outermost ring. Our
//! absolute spacings come out ≈1.15 px and ≈2.2 px: the radial map pushes the lattice corners
//! outwards (pincushion), and the corners set the field extent. The
//! physical scale of the profile (one cone per cell at Watson's 14 804.6 cones/deg²) would put the
//! edge at ≈1.5° — the same order; only the relative profile matters after step 3.
//!
//! Identity layout (official `Identity`, the sandbox): `field_px = n`, cone (i, j) at pixel
//! (j, i), no jitter.

use rand::rngs::StdRng;
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use super::density::{RadialDensity, RadialMap};
use super::perlin::{
    perlin_octaves, OFFICIAL_BASE_RESOLUTION, OFFICIAL_OCTAVES, OFFICIAL_PERSISTENCE,
};

/// Eccentricity (deg) of the middle of the lattice edge; fitted to the official spacing ratio
/// (module docs).
pub const DEFAULT_EDGE_ECCENTRICITY_DEG: f64 = 1.25;
/// The jitter field is generated on a lattice this many times the patch side (official: the
/// 512 lattice around the 256 patch).
pub const JITTER_LATTICE_OVERSIZE: usize = 2;
/// The "centre" of [`ConeLayout::centre_spacing_px`] reaches this many cells beyond the central
/// one (even n: a 4×4 block).
pub const CENTRE_BLOCK_HALF: usize = 1;

/// Perlin jitter settings (authors' code, docs/references.md#foveation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JitterConfig {
    /// Number of octaves (official 6).
    pub octaves: usize,
    /// Amplitude ratio per octave (official 0.8).
    pub persistence: f64,
    /// Noise periods across the oversized lattice in the first octave (official 2).
    pub base_resolution: usize,
    /// Multiplies the noise (1 = official, in lattice cells).
    pub amplitude_cells: f64,
}

impl Default for JitterConfig {
    fn default() -> Self {
        JitterConfig {
            octaves: OFFICIAL_OCTAVES,
            persistence: OFFICIAL_PERSISTENCE,
            base_resolution: OFFICIAL_BASE_RESOLUTION,
            amplitude_cells: 1.0,
        }
    }
}

/// Foveated layout settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FoveationConfig {
    /// Radial density profile.
    pub density: RadialDensity,
    /// Eccentricity (deg) of the middle of the lattice edge; `None` = physical scale.
    pub edge_eccentricity_deg: Option<f64>,
    /// Perlin jitter; `None` = a perfectly smooth lattice.
    pub jitter: Option<JitterConfig>,
}

impl Default for FoveationConfig {
    fn default() -> Self {
        FoveationConfig {
            density: RadialDensity::default(),
            edge_eccentricity_deg: Some(DEFAULT_EDGE_ECCENTRICITY_DEG),
            jitter: Some(JitterConfig::default()),
        }
    }
}

/// Which layout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum LayoutConfig {
    /// Regular grid, one cone per field pixel (sandbox).
    Identity,
    /// Foveated retinotopic lattice.
    Foveated(FoveationConfig),
}

/// Cone positions in the scene field (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ConeLayout {
    /// Cones per side.
    pub n: usize,
    /// Side of the scene field the cones sample, px.
    pub field_px: usize,
    /// Row-major `(n·n)` positions `[x, y]`, px.
    pub positions_px: Vec<[f32; 2]>,
    /// Row-major `(n·n)` jitter `[dx, dy]` applied in lattice cells (zeros without jitter).
    pub jitter_cells: Vec<[f32; 2]>,
    /// Eccentricity (deg) per field pixel, for reporting (0 for the identity layout).
    pub deg_per_px: f64,
}

impl ConeLayout {
    /// The identity layout: `n × n` cones on the pixels of an `n`-px field.
    pub fn identity(n: usize) -> ConeLayout {
        let positions_px = (0..n * n)
            .map(|c| [(c % n) as f32, (c / n) as f32])
            .collect();
        ConeLayout {
            n,
            field_px: n,
            positions_px,
            jitter_cells: vec![[0.0; 2]; n * n],
            deg_per_px: 0.0,
        }
    }

    /// Build a layout (module docs). For [`LayoutConfig::Identity`], `field_px` must equal `n`.
    pub fn compute(config: &LayoutConfig, n: usize, field_px: usize, seed: u64) -> ConeLayout {
        assert!(n >= 2, "ConeLayout::compute: n = {n} must be ≥ 2");
        match config {
            LayoutConfig::Identity => {
                assert_eq!(
                    n, field_px,
                    "ConeLayout::compute: identity layout needs field_px = n ({field_px} vs {n})"
                );
                ConeLayout::identity(n)
            }
            LayoutConfig::Foveated(f) => foveated(f, n, field_px, seed),
        }
    }

    /// Positions in the official normalised units, `[−1, 1]` over the field (x, y).
    pub fn positions_normalised(&self) -> Vec<[f32; 2]> {
        let s = 2.0 / (self.field_px as f32 - 1.0);
        self.positions_px
            .iter()
            .map(|p| [p[0] * s - 1.0, p[1] * s - 1.0])
            .collect()
    }

    /// Mean distance (px) from each cone to its 2–4 lattice neighbours, row-major `(n, n)`.
    pub fn spacing_px(&self) -> Vec<f32> {
        let n = self.n;
        let p = &self.positions_px;
        let d = |a: usize, b: usize| (p[a][0] - p[b][0]).hypot(p[a][1] - p[b][1]);
        let mut sum = vec![0.0f32; n * n];
        let mut count = vec![0u32; n * n];
        for i in 0..n {
            for j in 0..n {
                let c = i * n + j;
                if j + 1 < n {
                    let v = d(c, c + 1);
                    sum[c] += v;
                    sum[c + 1] += v;
                    count[c] += 1;
                    count[c + 1] += 1;
                }
                if i + 1 < n {
                    let v = d(c, c + n);
                    sum[c] += v;
                    sum[c + n] += v;
                    count[c] += 1;
                    count[c + n] += 1;
                }
            }
        }
        sum.iter().zip(&count).map(|(s, &k)| s / k as f32).collect()
    }

    /// Mean spacing of the central 4×4 (odd n: 3×3) cells, px.
    pub fn centre_spacing_px(&self) -> f64 {
        let (n, s) = (self.n, self.spacing_px());
        let (lo, hi) = ((n - 1) / 2, n / 2);
        let (lo, hi) = (
            lo.saturating_sub(CENTRE_BLOCK_HALF),
            (hi + CENTRE_BLOCK_HALF).min(n - 1),
        );
        let mut acc = (0.0, 0);
        for i in lo..=hi {
            for j in lo..=hi {
                acc.0 += s[i * n + j] as f64;
                acc.1 += 1;
            }
        }
        acc.0 / acc.1 as f64
    }

    /// Mean spacing of the outermost ring of cells, px.
    pub fn edge_spacing_px(&self) -> f64 {
        let (n, s) = (self.n, self.spacing_px());
        let ring: Vec<f64> = (0..n * n)
            .filter(|&c| {
                let (i, j) = (c / n, c % n);
                i == 0 || j == 0 || i == n - 1 || j == n - 1
            })
            .map(|c| s[c] as f64)
            .collect();
        ring.iter().sum::<f64>() / ring.len() as f64
    }

    /// Edge spacing / centre spacing (official ≈ 1.9 for the paper layout).
    pub fn centre_to_edge_spacing_ratio(&self) -> f64 {
        self.edge_spacing_px() / self.centre_spacing_px()
    }

    /// Signed area (px², shoelace, positive for the identity orientation) of every lattice cell
    /// spanned by cones (i, j), (i, j+1), (i+1, j+1), (i+1, j); row-major `(n−1, n−1)`.
    pub fn cell_signed_areas_px2(&self) -> Vec<f64> {
        let (n, p) = (self.n, &self.positions_px);
        let mut out = Vec::with_capacity((n - 1) * (n - 1));
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                let q = [
                    p[i * n + j],
                    p[i * n + j + 1],
                    p[(i + 1) * n + j + 1],
                    p[(i + 1) * n + j],
                ];
                let mut a = 0.0f64;
                for k in 0..4 {
                    let (u, v) = (q[k], q[(k + 1) % 4]);
                    a += u[0] as f64 * v[1] as f64 - v[0] as f64 * u[1] as f64;
                }
                out.push(0.5 * a);
            }
        }
        out
    }

    /// The official rule for the field resolution a layout needs (authors' code, docs/references.md#foveation, step 4):
    /// `2^ceil(log2(1/s))`, s = mean of the 10 smallest neighbour spacings in [0, 1] field units.
    pub fn required_field_px(&self) -> usize {
        let (n, p) = (self.n, &self.positions_px);
        let scale = 1.0 / (self.field_px as f64 - 1.0);
        let mut d: Vec<f64> = Vec::with_capacity(2 * n * n);
        for i in 0..n {
            for j in 0..n {
                let c = i * n + j;
                let mut push = |b: usize| {
                    d.push(((p[c][0] - p[b][0]) as f64).hypot((p[c][1] - p[b][1]) as f64) * scale)
                };
                if j + 1 < n {
                    push(c + 1);
                }
                if i + 1 < n {
                    push(c + n);
                }
            }
        }
        d.sort_by(f64::total_cmp);
        let k = d.len().min(10);
        let s = d[..k].iter().sum::<f64>() / k as f64;
        1usize << (1.0 / s).log2().ceil() as u32
    }
}

fn foveated(cfg: &FoveationConfig, n: usize, field_px: usize, seed: u64) -> ConeLayout {
    let centre = (n as f64 - 1.0) / 2.0;
    let map = match cfg.edge_eccentricity_deg {
        Some(e) => RadialMap::with_edge(cfg.density, centre, e),
        None => RadialMap::physical(cfg.density),
    };
    let mut jitter = vec![[0.0f32; 2]; n * n];
    if let Some(j) = cfg.jitter {
        let mut rng = StdRng::seed_from_u64(seed);
        let big = JITTER_LATTICE_OVERSIZE * n;
        let off = (big - n) / 2;
        let field = |rng: &mut StdRng| {
            perlin_octaves(rng, big, big, j.base_resolution, j.octaves, j.persistence)
        };
        // x first, then y, from one random stream
        let fx = field(&mut rng);
        let fy = field(&mut rng);
        // Official: the outermost ring of the (oversized) noise lattice is zeroed. It lies
        // outside the patch, so the patch sees a smooth field right up to its boundary.
        let ring = |r: usize, c: usize| r == 0 || c == 0 || r == big - 1 || c == big - 1;
        for i in 0..n {
            for k in 0..n {
                let (r, c) = (i + off, k + off);
                if ring(r, c) {
                    continue;
                }
                let b = r * big + c;
                jitter[i * n + k] = [
                    (fx[b] * j.amplitude_cells) as f32,
                    (fy[b] * j.amplitude_cells) as f32,
                ];
            }
        }
    }
    let deg: Vec<(f64, f64)> = (0..n * n)
        .map(|c| {
            let (i, j) = (c / n, c % n);
            map.map(
                j as f64 - centre + jitter[c][0] as f64,
                i as f64 - centre + jitter[c][1] as f64,
            )
        })
        .collect();
    let lo = deg
        .iter()
        .map(|p| p.0.min(p.1))
        .fold(f64::INFINITY, f64::min);
    let hi = deg
        .iter()
        .map(|p| p.0.max(p.1))
        .fold(f64::NEG_INFINITY, f64::max);
    let px_per_deg = (field_px as f64 - 1.0) / (hi - lo);
    let positions_px = deg
        .iter()
        .map(|&(x, y)| {
            [
                ((x - lo) * px_per_deg) as f32,
                ((y - lo) * px_per_deg) as f32,
            ]
        })
        .collect();
    ConeLayout {
        n,
        field_px,
        positions_px,
        jitter_cells: jitter,
        deg_per_px: 1.0 / px_per_deg,
    }
}

#[cfg(test)]
mod tests;
