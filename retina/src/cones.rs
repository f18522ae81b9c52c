//! Photoreceptors: cone activation and photon noise (authors' code, docs/references.md#cone-activation-and-noise, paper S-02).
//!
//! Stage `Cones::compute(stack, origin, noise, out)`:
//! - input: the scene tile's class planes as a [`MipStack`] `(levels, k, h, w)` — the scene
//!   already projected onto the mosaic's k distinct cone classes (dimensionless cone
//!   excitations, white ≈ 1 after white balance) — and the field origin in the tile (px);
//! - output: activation `a = Σ_k w_k · plane_k(position)` per cone, `(n, n)` row-major f32
//!   (official: `pa = Σ_c LMSQ_c · mosaic_c`).
//!
//! Photon noise: `a ← a + σ·ε`, ε ~ N(0, 1), `σ = 0.01 · r · √max(a, 0) + 1e-10`, where the noise
//! ratio `r = k/10` with k uniform in {0, …, 10} is drawn once per batch (authors' code, docs/references.md#cone-activation-and-noise; SNR
//! ≈ 100 at a = 1, r = 1, paper S-02). [`NoiseConfig::enabled`] = false gives the noise-free
//! path.

use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::foveation::{ConeSampler, MipStack};
use crate::mosaic::Mosaic;

/// Photon-noise scale at r = 1 (authors' code, docs/references.md#cone-activation-and-noise).
pub const OFFICIAL_PHOTON_NOISE_SCALE: f32 = 0.01;
/// Lateral-inhibition noise scale at r = 1 (authors' code, docs/references.md#lateral-inhibition).
pub const OFFICIAL_LI_NOISE_SCALE: f32 = 0.01;
/// r = k / levels with k uniform in {0, …, levels} (authors' code, docs/references.md#cone-activation-and-noise: 10).
pub const OFFICIAL_NOISE_LEVELS: u32 = 10;
/// Floor added to the photon-noise σ (authors' code, docs/references.md#cone-activation-and-noise).
pub const PHOTON_NOISE_SIGMA_FLOOR: f32 = 1e-10;

/// Noise settings of the retina (photon noise and the multiplicative noise after LI).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseConfig {
    /// Whether any noise is added.
    pub enabled: bool,
    /// σ = photon_noise_scale · r · √a.
    pub photon_noise_scale: f32,
    /// LI output ← out · (1 + li_noise_scale · r · ε).
    pub li_noise_scale: f32,
    /// r = k / noise_levels, k uniform in {0, …, noise_levels}.
    pub noise_levels: u32,
}

impl Default for NoiseConfig {
    fn default() -> Self {
        NoiseConfig {
            enabled: true,
            photon_noise_scale: OFFICIAL_PHOTON_NOISE_SCALE,
            li_noise_scale: OFFICIAL_LI_NOISE_SCALE,
            noise_levels: OFFICIAL_NOISE_LEVELS,
        }
    }
}

impl NoiseConfig {
    /// No noise at all.
    pub fn off() -> Self {
        NoiseConfig {
            enabled: false,
            ..Self::default()
        }
    }

    /// Draw the per-batch noise ratio r (0 when disabled).
    pub fn draw_ratio<R: Rng + ?Sized>(&self, rng: &mut R) -> f32 {
        if !self.enabled || self.noise_levels == 0 {
            return 0.0;
        }
        rng.random_range(0..=self.noise_levels) as f32 / self.noise_levels as f32
    }
}

/// Add photon noise with ratio `r` in place (module docs).
pub fn add_photon_noise<R: Rng + ?Sized>(rng: &mut R, a: &mut [f32], scale: f32, r: f32) {
    if r == 0.0 || scale == 0.0 {
        return;
    }
    let s = scale * r;
    for v in a.iter_mut() {
        let sigma = s * v.max(0.0).sqrt() + PHOTON_NOISE_SIGMA_FLOOR;
        let e: f32 = rng.sample(StandardNormal);
        *v += sigma * e;
    }
}

/// The cone stage: mosaic weights and sampling taps.
#[derive(Debug, Clone)]
pub struct Cones {
    /// Row-major `(n·n, k)` class weights (from the mosaic).
    pub weights: Vec<f32>,
    /// Sampling taps of the layout.
    pub sampler: ConeSampler,
}

impl Cones {
    /// Combine a mosaic with the layout's sampler.
    pub fn new(mosaic: &Mosaic, sampler: ConeSampler) -> Self {
        assert_eq!(
            mosaic.n * mosaic.n,
            sampler.n_cones(),
            "Cones::new: mosaic {}² vs layout with {} cones",
            mosaic.n,
            sampler.n_cones()
        );
        Cones {
            weights: mosaic.weights.clone(),
            sampler,
        }
    }

    /// Noise-free activations at `origin` (module docs); `out` is `(n·n)`.
    pub fn compute(&self, stack: &MipStack, origin: [i32; 2], out: &mut [f32]) {
        self.sampler
            .sample_weighted(stack, &self.weights, origin, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    #[test]
    fn photon_noise_has_the_official_std() {
        let mut rng = StdRng::seed_from_u64(0);
        for (a0, r) in [(1.0f32, 1.0f32), (0.25, 0.5), (0.81, 0.0)] {
            let mut a = vec![a0; 200_000];
            add_photon_noise(&mut rng, &mut a, OFFICIAL_PHOTON_NOISE_SCALE, r);
            let mean = a.iter().map(|&v| v as f64).sum::<f64>() / a.len() as f64;
            let var = a.iter().map(|&v| (v as f64 - mean).powi(2)).sum::<f64>() / a.len() as f64;
            let want = 0.01 * r as f64 * (a0 as f64).sqrt();
            assert!((mean - a0 as f64).abs() < 1e-4);
            assert!(
                (var.sqrt() - want).abs() <= 0.02 * want + 1e-9,
                "{a0} {r}: {}",
                var.sqrt()
            );
        }
    }

    #[test]
    fn noise_ratio_takes_eleven_values() {
        let mut rng = StdRng::seed_from_u64(0);
        let n = NoiseConfig::default();
        let mut seen = [false; 11];
        for _ in 0..1000 {
            let r = n.draw_ratio(&mut rng);
            seen[(r * 10.0).round() as usize] = true;
            assert!((r * 10.0 - (r * 10.0).round()).abs() < 1e-6);
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(NoiseConfig::off().draw_ratio(&mut rng), 0.0);
    }
}
