//! Synthetic spectral scenes: dead leaves of measured surfaces under varying daylight.
//!
//! Stage `LeafScene::generate(config, library, rng)` builds the geometry and lighting of one
//! scene; `render_spectral` gives the `(wavelengths, h, w)` radiance image, `render_projected`
//! the same scene projected onto k classes without materialising spectra (exactly equal, by
//! linearity, to projecting `render_spectral`).
//!
//! Model (dead leaves: Matheron 1968; scale invariance and 1/f² power: Lee, Mumford & Huang
//! 2001; Ruderman 1997):
//! - Leaves fall front to back until every pixel is covered (occlusion: a pixel shows the first
//!   leaf that covers it). Leaf size r (px, radius of the equal-area disc) has density ∝ r^(−3)
//!   on `[radius_min_px, radius_max_fraction·size]` — the exponent that makes the model scale
//!   invariant, with a radially averaged power spectrum ∝ f^(−2). Shapes are ellipses or
//!   rectangles with random orientation and aspect ratio in `[1, max_aspect]`.
//! - Each leaf is a surface drawn uniformly from the measured reflectance library
//!   ([`super::library`]) with a brightness in `leaf_brightness_range` and a linear shading
//!   ramp across it (slope up to `leaf_shading_gradient` per leaf radius) — the surface's tilt to
//!   the light.
//! - Illumination: a sunlit daylight (CCT uniform in `sun_cct_k`) and a skylight (CCT uniform in
//!   `sky_cct_k`, luminance `sky_relative_luminance` of the sun), mixed per pixel by a smooth
//!   shadow map with soft edges, times a smooth log-normal intensity field
//!   (`illumination_log_amplitude`). Both fields are low-frequency Perlin noise.
//!
//! Pixel spectrum: `L(x, λ) = s(x)·[(1 − t(x))·E_sun(λ) + t(x)·κ·E_sky(λ)]·R_leaf(x)(λ)`.

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::library::{daylight_unit_luminance, ReflectanceLibrary};
use super::{Projector, SpectralImage};
use crate::error::Result;
use crate::foveation::perlin::perlin_octaves;
use leaf::{uniform, Leaf, SizeLaw, UNSET};

mod leaf;

/// Dead-leaves settings (module docs; every number is a modelling choice of ours unless noted).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeadLeavesConfig {
    /// Scene side, px.
    pub size_px: usize,
    /// Smallest leaf radius, px.
    pub radius_min_px: f64,
    /// Largest leaf radius as a fraction of the scene side.
    pub radius_max_fraction: f64,
    /// Exponent α of the size density r^(−α); 3 is scale invariant (Lee et al. 2001).
    pub size_exponent: f64,
    /// Largest aspect ratio of a leaf.
    pub max_aspect: f64,
    /// Fraction of leaves that are rectangles (the rest are ellipses).
    pub rectangle_fraction: f64,
    /// Brightness factor range of a leaf.
    pub leaf_brightness_range: [f64; 2],
    /// Largest shading slope across a leaf, per leaf radius.
    pub leaf_shading_gradient: f64,
    /// Sunlight CCT range, K.
    pub sun_cct_k: [f64; 2],
    /// Skylight (shadow) CCT range, K.
    pub sky_cct_k: [f64; 2],
    /// Skylight luminance relative to the sun.
    pub sky_relative_luminance: f64,
    /// Amplitude of the log illumination field (natural log units per unit Perlin noise).
    pub illumination_log_amplitude: f64,
    /// Steepness of the shadow edges (logistic gain on Perlin noise).
    pub shadow_edge_gain: f64,
    /// Stop after this many leaves; uncovered pixels then show the last leaf.
    pub max_leaves: usize,
}

impl Default for DeadLeavesConfig {
    fn default() -> Self {
        DeadLeavesConfig {
            size_px: 256,
            radius_min_px: 1.5,
            radius_max_fraction: 0.3,
            size_exponent: 3.0,
            max_aspect: 2.5,
            rectangle_fraction: 0.4,
            leaf_brightness_range: [0.3, 1.0],
            leaf_shading_gradient: 0.3,
            sun_cct_k: [4000.0, 7000.0],
            sky_cct_k: [7000.0, 20000.0],
            sky_relative_luminance: 0.3,
            illumination_log_amplitude: 0.5,
            shadow_edge_gain: 6.0,
            max_leaves: 400_000,
        }
    }
}

/// Geometry and lighting of one dead-leaves scene (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct LeafScene {
    /// Rows (= columns).
    pub size_px: usize,
    /// Leaf index per pixel, row-major.
    pub label: Vec<u32>,
    /// Intensity factor s(x) per pixel (leaf brightness, leaf shading, illumination field).
    pub shading: Vec<f32>,
    /// Shadow weight t(x) ∈ [0, 1] per pixel.
    pub shadow: Vec<f32>,
    /// Library index of each leaf's reflectance.
    pub surface: Vec<u32>,
    /// Library index of each leaf's second pigment ([`super::surfaces`]); empty: none.
    pub second_surface: Vec<u32>,
    /// Weight of the second pigment per pixel, in `[0, 1]`; empty: none.
    pub mix: Vec<f32>,
    /// Sunlight, unit luminance, on the library's grid.
    pub sun: Vec<f64>,
    /// Skylight times its relative luminance, on the library's grid.
    pub sky: Vec<f64>,
}

fn smooth_field<R: Rng + ?Sized>(rng: &mut R, size: usize) -> Vec<f64> {
    perlin_octaves(rng, size, size, 2, 3, 0.5)
}

/// Multiplies `shading` by the smooth log-normal illumination field and returns the shadow
/// weight t(x) of the soft-edged shadow map (both fields drawn from `rng`, in that order).
fn light_and_shadow<R: Rng + ?Sized>(
    cfg: &DeadLeavesConfig,
    rng: &mut R,
    shading: &mut [f32],
) -> Vec<f32> {
    let n = cfg.size_px;
    let light = smooth_field(rng, n);
    let shadow_noise = smooth_field(rng, n);
    let mut shadow = vec![0.0f32; n * n];
    for p in 0..n * n {
        shading[p] *= (cfg.illumination_log_amplitude * light[p]).exp() as f32;
        shadow[p] = (1.0 / (1.0 + (-cfg.shadow_edge_gain * shadow_noise[p]).exp())) as f32;
    }
    shadow
}

impl LeafScene {
    /// Draw a scene (module docs).
    pub fn generate<R: Rng + ?Sized>(
        cfg: &DeadLeavesConfig,
        lib: &ReflectanceLibrary,
        rng: &mut R,
    ) -> Result<LeafScene> {
        let n = cfg.size_px;
        assert!(
            n >= 2 && !lib.is_empty(),
            "LeafScene::generate: size {n}, library empty"
        );
        let sun = daylight_unit_luminance(uniform(rng, cfg.sun_cct_k), &lib.grid)?;
        let sky: Vec<f64> = daylight_unit_luminance(uniform(rng, cfg.sky_cct_k), &lib.grid)?
            .into_iter()
            .map(|v| v * cfg.sky_relative_luminance)
            .collect();
        let mut label = vec![UNSET; n * n];
        let mut shading = vec![0.0f32; n * n];
        let mut surface = Vec::new();
        let mut remaining = n * n;
        let sizes = SizeLaw::new(cfg);
        while remaining > 0 && surface.len() < cfg.max_leaves {
            let leaf = Leaf::draw(cfg, &sizes, rng);
            let id = surface.len() as u32;
            surface.push(rng.random_range(0..lib.len()) as u32);
            remaining -= leaf.paint(id, n, &mut label, &mut shading);
        }
        if remaining > 0 {
            let last = surface.len().saturating_sub(1) as u32;
            for (l, s) in label.iter_mut().zip(shading.iter_mut()) {
                if *l == UNSET {
                    *l = last;
                    *s = 0.5;
                }
            }
        }
        let shadow = light_and_shadow(cfg, rng, &mut shading);
        Ok(LeafScene {
            size_px: n,
            label,
            shading,
            shadow,
            surface,
            second_surface: Vec::new(),
            mix: Vec::new(),
            sun,
            sky,
        })
    }

    /// Number of leaves drawn.
    pub fn n_leaves(&self) -> usize {
        self.surface.len()
    }

    /// The radiance image on the library's grid.
    pub fn render_spectral(&self, lib: &ReflectanceLibrary) -> SpectralImage {
        let n = self.size_px;
        let nl = lib.grid.len();
        let mut img = SpectralImage::zeros(lib.grid.clone(), n, n);
        for p in 0..n * n {
            let leaf = self.label[p] as usize;
            let refl = &lib.spectra[self.surface[leaf] as usize];
            let (w, second) = self.second_pigment(leaf, p, lib);
            let (s, t) = (self.shading[p] as f64, self.shadow[p] as f64);
            for l in 0..nl {
                let e = (1.0 - t) * self.sun[l] + t * self.sky[l];
                let r = (1.0 - w) * refl[l] + w * second[l];
                img.data[l * n * n + p] = (s * e * r) as f32;
            }
        }
        img
    }

    /// The weight and reflectance of the second pigment at pixel `p` of `leaf` (weight 0 and
    /// the leaf's own reflectance when the scene has none).
    fn second_pigment<'a>(
        &self,
        leaf: usize,
        p: usize,
        lib: &'a ReflectanceLibrary,
    ) -> (f64, &'a [f64]) {
        if self.mix.is_empty() {
            return (0.0, &lib.spectra[self.surface[leaf] as usize]);
        }
        (
            self.mix[p] as f64,
            &lib.spectra[self.second_surface[leaf] as usize],
        )
    }

    /// The scene projected by `proj` (same grid as the library): `(k, h, w)`.
    pub fn render_projected(&self, lib: &ReflectanceLibrary, proj: &Projector) -> Vec<f32> {
        assert_eq!(
            proj.grid, lib.grid,
            "LeafScene::render_projected: projector and library grids differ"
        );
        let (n, k, nl) = (self.size_px, proj.k, lib.grid.len());
        // Per leaf and pigment: excitations under sun and under sky.
        let pigments = if self.mix.is_empty() { 1 } else { 2 };
        let mut under = vec![0.0f32; self.surface.len() * 2 * pigments * k];
        let mut used = vec![false; self.surface.len()];
        for &l in &self.label {
            used[l as usize] = true;
        }
        let at = |leaf: usize, pigment: usize, light: usize| {
            ((leaf * pigments + pigment) * 2 + light) * k
        };
        for leaf in (0..self.surface.len()).filter(|&l| used[l]) {
            for pigment in 0..pigments {
                let surf = if pigment == 0 {
                    self.surface[leaf]
                } else {
                    self.second_surface[leaf]
                };
                let refl = &lib.spectra[surf as usize];
                for c in 0..k {
                    let m = &proj.matrix[c * nl..(c + 1) * nl];
                    let (mut a, mut b) = (0.0f64, 0.0f64);
                    for l in 0..nl {
                        a += m[l] as f64 * self.sun[l] * refl[l];
                        b += m[l] as f64 * self.sky[l] * refl[l];
                    }
                    under[at(leaf, pigment, 0) + c] = a as f32;
                    under[at(leaf, pigment, 1) + c] = b as f32;
                }
            }
        }
        let mut out = vec![0.0f32; k * n * n];
        for p in 0..n * n {
            let leaf = self.label[p] as usize;
            let (s, t) = (self.shading[p], self.shadow[p]);
            let w = if pigments == 2 { self.mix[p] } else { 0.0 };
            for c in 0..k {
                let light = |l: usize| {
                    let first = under[at(leaf, 0, l) + c];
                    if pigments == 2 {
                        first + w * (under[at(leaf, 1, l) + c] - first)
                    } else {
                        first
                    }
                };
                out[c * n * n + p] = s * ((1.0 - t) * light(0) + t * light(1));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use colorimetry::{sensitivities, ConeClass, ConeTemplate, WavelengthGrid};
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    #[test]
    fn leaves_cover_the_scene_and_projection_commutes_with_rendering() {
        let g = WavelengthGrid::default();
        let lib = ReflectanceLibrary::measured(&g).unwrap();
        let cfg = DeadLeavesConfig {
            size_px: 96,
            ..DeadLeavesConfig::default()
        };
        let mut rng = StdRng::seed_from_u64(4);
        let scene = LeafScene::generate(&cfg, &lib, &mut rng).unwrap();
        assert!(scene.n_leaves() > 50 && scene.n_leaves() < cfg.max_leaves);
        let visible: std::collections::HashSet<u32> = scene.label.iter().copied().collect();
        assert!(visible.len() > 30, "{} visible leaves", visible.len());
        let f = sensitivities(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
        let proj = Projector::cones(&f);
        let direct = scene.render_projected(&lib, &proj);
        let via = proj.project_image(&scene.render_spectral(&lib));
        for (a, b) in direct.iter().zip(&via) {
            assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{a} vs {b}");
        }
        assert!(direct.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
}
