//! Synthetic scenes whose spatial statistics match photographs: large surfaces of measured
//! reflectance, textured in brightness, with a slow within-surface change of pigment.
//!
//! Stage `surface_scene(config, library, size_px, rng)` → a [`LeafScene`] rendered like dead
//! leaves (`render_spectral`, `render_projected`).
//!
//! Model (units: px at the eyes' 2 px per cone; every number a modelling choice of ours, some
//! fitted to photographs as `docs/notebook/2026-11-28-scene-statistics.md` describes: each
//! field of [`SurfacesConfig`] says which):
//! - **Surfaces**: dead leaves (occlusion, random ellipses and rectangles; [`super::dead_leaves`])
//!   whose radius density ∝ r^(−α) runs from `leaves.radius_min_px` to an absolute
//!   `radius_max_px` (not a fraction of the tile), so every eye, whatever its tile, sees
//!   surfaces of the same size in cone spacings. Each surface has one measured reflectance —
//!   colour is coherent over a surface, as in photographs, where two points 8 px apart keep a
//!   chromatic correlation of 0.5–0.96 against the classic dead leaves' 0.2.
//! - **Texture** (what makes most of a photograph's fine structure luminance, not chroma): a
//!   fractal log-brightness field per surface, `shading ← shading · exp(a·T_k(x))` with `T_k`
//!   one of `texture_fields` unit-variance Perlin fields (octaves from `texture_period_px` down
//!   by halves, persistence `texture_persistence`) and `a` uniform in `[0, texture_log_sigma]`.
//! - **Pigment variation**: each surface mixes its reflectance with a second one drawn from the
//!   library, weight `w(x) = m·(1 + P_k(x))/2` clipped to `[0, 1]`, `P_k` a smooth
//!   unit-variance field of period `pigment_period_px`, `m` uniform in `[0, pigment_mix_max]`:
//!   the slow hue changes across a leaf, a face or a wall (reflectance mixtures stay physical).
//! - **Light**: the dead leaves' sun and sky daylights, soft shadows and illumination field.
//!
//! Pixel spectrum: `L(x, λ) = s(x)·[(1 − t(x))·E_sun(λ) + t(x)·κ·E_sky(λ)]·
//! [(1 − w(x))·R₁(λ) + w(x)·R₂(λ)]` for the surface covering `x`.

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::dead_leaves::{DeadLeavesConfig, LeafScene};
use super::library::ReflectanceLibrary;
use crate::error::Result;
use crate::foveation::perlin::perlin_octaves;

/// Surface-scene settings (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfacesConfig {
    /// Shapes, sizes, brightness and light of the surfaces, as dead leaves
    /// (`radius_max_fraction` is replaced by `radius_max_px` over the tile side).
    pub leaves: DeadLeavesConfig,
    /// Largest surface radius, px. Default 400: chosen here (its diameter, 800 px, exceeds every
    /// preset's tile, 96–576 px, so the largest surfaces cover a whole tile, as walls and sky
    /// do in photographs); not searched.
    pub radius_max_px: f64,
    /// Largest standard deviation of a surface's log-brightness texture (natural-log units).
    /// Default 0.3: grid-searched over 0.2–0.5 against the fit photographs' median curves
    /// (`docs/notebook/2026-11-28-scene-statistics.md`).
    pub texture_log_sigma: f64,
    /// Period of the texture's coarsest octave, px. Default 64: chosen here; not searched.
    pub texture_period_px: f64,
    /// Octaves of the texture (each half the period of the one before). Default 5 (64 px down
    /// to 4 px, two cone spacings): chosen here; not searched.
    pub texture_octaves: usize,
    /// Amplitude ratio of successive texture octaves (0.5: about 1/f² power). Default 0.6:
    /// chosen here; not searched.
    pub texture_persistence: f64,
    /// Largest weight of a surface's second pigment. Default 1: grid-searched over 0.5–1
    /// (`docs/notebook/2026-11-28-scene-statistics.md`).
    pub pigment_mix_max: f64,
    /// Period of the pigment-weight field's coarsest octave, px. Default 16: grid-searched over
    /// 16 and 32 (`docs/notebook/2026-11-28-scene-statistics.md`).
    pub pigment_period_px: f64,
    /// Octaves of the pigment-weight field. Default 4: grid-searched over 4 and 6
    /// (`docs/notebook/2026-11-28-scene-statistics.md`).
    pub pigment_octaves: usize,
    /// Amplitude ratio of successive pigment octaves. Default 0.5: chosen here; not searched.
    pub pigment_persistence: f64,
    /// Independent texture (and pigment) fields per scene; each surface draws one of them.
    /// Default 4: chosen here (a cost bound: each field is one Perlin sum over the tile).
    pub texture_fields: usize,
}

impl Default for SurfacesConfig {
    fn default() -> Self {
        SurfacesConfig {
            // Smallest radius 24 px and size exponent 2.8: grid-searched against photographs
            // (16–32 px × 2.8–3.2 first, then 2.8/3.0 with the pigment settings;
            // `docs/notebook/2026-11-28-scene-statistics.md`).
            leaves: DeadLeavesConfig {
                radius_min_px: 24.0,
                size_exponent: 2.8,
                ..DeadLeavesConfig::default()
            },
            radius_max_px: 400.0,
            texture_log_sigma: 0.3,
            texture_period_px: 64.0,
            texture_octaves: 5,
            texture_persistence: 0.6,
            pigment_mix_max: 1.0,
            pigment_period_px: 16.0,
            pigment_octaves: 4,
            pigment_persistence: 0.5,
            texture_fields: 4,
        }
    }
}

/// `count` unit-variance fractal fields on an `n × n` grid, coarsest period `period_px`.
fn unit_fields<R: Rng + ?Sized>(
    rng: &mut R,
    n: usize,
    count: usize,
    period_px: f64,
    octaves: usize,
    persistence: f64,
) -> Vec<Vec<f32>> {
    let base = ((n as f64 / period_px).round() as usize).max(1);
    (0..count)
        .map(|_| {
            let f = perlin_octaves(rng, n, n, base, octaves.max(1), persistence);
            let mean = f.iter().sum::<f64>() / f.len() as f64;
            let var = f.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / f.len() as f64;
            let inv = 1.0 / var.sqrt().max(1e-12);
            f.iter().map(|v| ((v - mean) * inv) as f32).collect()
        })
        .collect()
}

/// A surface scene of side `size_px` (module docs), as a [`LeafScene`] with a second pigment.
pub fn surface_scene<R: Rng + ?Sized>(
    cfg: &SurfacesConfig,
    lib: &ReflectanceLibrary,
    size_px: usize,
    rng: &mut R,
) -> Result<LeafScene> {
    let leaves = DeadLeavesConfig {
        size_px,
        radius_max_fraction: cfg.radius_max_px / size_px as f64,
        ..cfg.leaves.clone()
    };
    let mut scene = LeafScene::generate(&leaves, lib, rng)?;
    let n = size_px;
    let k = cfg.texture_fields.max(1);
    let texture = unit_fields(
        rng,
        n,
        k,
        cfg.texture_period_px,
        cfg.texture_octaves,
        cfg.texture_persistence,
    );
    let pigment = unit_fields(
        rng,
        n,
        k,
        cfg.pigment_period_px,
        cfg.pigment_octaves,
        cfg.pigment_persistence,
    );
    let n_leaves = scene.surface.len();
    let per_leaf: Vec<(usize, f32, f32)> = (0..n_leaves)
        .map(|_| {
            (
                rng.random_range(0..k),
                (cfg.texture_log_sigma * rng.random::<f64>()) as f32,
                (cfg.pigment_mix_max * rng.random::<f64>()) as f32,
            )
        })
        .collect();
    scene.second_surface = (0..n_leaves)
        .map(|_| rng.random_range(0..lib.len()) as u32)
        .collect();
    scene.mix = vec![0.0; n * n];
    for p in 0..n * n {
        let (field, amp, mix) = per_leaf[scene.label[p] as usize];
        scene.shading[p] *= (amp * texture[field][p]).exp();
        scene.mix[p] = (mix * 0.5 * (1.0 + pigment[field][p])).clamp(0.0, 1.0);
    }
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Projector;
    use colorimetry::{sensitivities, ConeClass, ConeTemplate, WavelengthGrid};
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    /// Projection commutes with spectral rendering (the second pigment included, by
    /// linearity), weights stay in [0, 1], and a surface scene has far fewer visible surfaces
    /// than classic dead leaves of the same size.
    #[test]
    fn surfaces_render_consistently_and_are_large() {
        let g = WavelengthGrid::default();
        let lib = ReflectanceLibrary::measured(&g).unwrap();
        let mut rng = StdRng::seed_from_u64(9);
        let scene = surface_scene(&SurfacesConfig::default(), &lib, 96, &mut rng).unwrap();
        assert!(scene.mix.iter().all(|w| (0.0..=1.0).contains(w)));
        assert!(
            scene.mix.iter().any(|&w| w > 0.05),
            "some surface mixes in its second pigment"
        );
        let f = sensitivities(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
        let proj = Projector::cones(&f);
        let direct = scene.render_projected(&lib, &proj);
        let via = proj.project_image(&scene.render_spectral(&lib));
        for (a, b) in direct.iter().zip(&via) {
            assert!((a - b).abs() <= 1e-4 * b.abs().max(1.0), "{a} vs {b}");
        }
        let visible = |labels: &[u32]| {
            labels
                .iter()
                .collect::<std::collections::HashSet<_>>()
                .len()
        };
        let classic = LeafScene::generate(
            &DeadLeavesConfig {
                size_px: 96,
                ..DeadLeavesConfig::default()
            },
            &lib,
            &mut rng,
        )
        .unwrap();
        assert!(
            4 * visible(&scene.label) < visible(&classic.label),
            "{} surfaces against {} leaves",
            visible(&scene.label),
            visible(&classic.label)
        );
    }
}
