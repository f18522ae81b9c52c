//! An observer's hue sphere: one most-saturated surface colour per hue (Lee et al. 2024, the
//! tetrachromatic hue sphere; paper S-07 samples its second environment from it).
//!
//! Conventions:
//! - A colour is the class excitations of a reflectance under a reference daylight
//!   ([`HUE_SPHERE_DAYLIGHT_CCT_K`]), each class divided by its response to the perfect white
//!   (reflectance 1), so the achromatic axis is `(1, …, 1)`.
//! - A hue is a unit direction `d` orthogonal to that axis: a point on a sphere of dimension
//!   k − 2 — two points for a dichromat, a circle for a trichromat, a 2-sphere for a
//!   tetrachromat. [`HueSphere::random_hue`] draws it uniformly (an isotropic Gaussian projected
//!   off the achromatic axis, normalised).
//! - The surface colours of an observer form a zonotope (the object-colour solid), so the one
//!   that reaches furthest along `d` is its support point: reflectance 1 wherever
//!   `Σ_c d_c·F̃_c(λ) > 0` and 0 elsewhere, with `F̃_c = F_c·E·Δλ / white_c`
//!   ([`HueSphere::reflectance`]). These are optimal colours in Schrödinger's (1920) sense, exact
//!   on the wavelength grid, and they depend on the observer: a pigeon-Q and a human-Q
//!   tetrachromat get different sets.
//!
//! A monochromat has no hue; [`HueSphere::new`] refuses fewer than two classes.
//!
//! How a hue becomes a colour is a [`HueRule`]: the support point above (the default), or the
//! most chromatic colour of each hue in a max basis ([`max_chroma`]), which spreads the colours
//! over the hues (docs/notebook/2026-12-03-hue-sphere-colours.md measures both).

use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::library::{daylight_unit_luminance, ReflectanceLibrary};
use super::Projector;
use crate::error::{Result, RetinaError};

/// Correlated colour temperature of the reference daylight the hue sphere is computed under, K
/// (CIE D65's nominal 6504 K; CIE 015:2018).
pub const HUE_SPHERE_DAYLIGHT_CCT_K: f64 = 6504.0;

pub mod max_chroma;

/// How a drawn hue becomes a surface colour.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HueRule {
    /// Hues drawn uniformly in white-normalised cone coordinates; the colour is the optimal
    /// colour that reaches furthest along the hue ([`HueSphere::reflectance`]).
    #[default]
    SupportPoint,
    /// Hues drawn uniformly in a max basis (Lee et al. 2024); the colour is the surface whose
    /// chroma goes furthest along exactly that hue ([`max_chroma`]).
    MaxChroma,
}

impl HueRule {
    /// Whether this is the default rule (a run's config leaves the default unwritten).
    pub fn is_default(&self) -> bool {
        *self == HueRule::default()
    }
}

/// The weights `F̃_c(λ)` of an observer's classes (module docs).
#[derive(Debug, Clone)]
pub struct HueSphere {
    /// `k` rows of `grid.len()` white-normalised weights.
    weights: Vec<Vec<f64>>,
    grid: colorimetry::WavelengthGrid,
}

impl HueSphere {
    /// The first `k` rows of `projector` (the observer's classes, `F_c(λ)·Δλ`) under the
    /// reference daylight. Error for `k < 2` (no hue) or `k` beyond the projector's rows.
    pub fn new(projector: &Projector, k: usize) -> Result<Self> {
        if k < 2 || k > projector.k {
            return Err(RetinaError::setting(
                "scenes.tetra.environment",
                format!(
                    "the hue sphere needs at least two cone classes and at most the eye's {}; \
                     got {k}",
                    projector.k
                ),
            ));
        }
        let grid = projector.grid.clone();
        let daylight = daylight_unit_luminance(HUE_SPHERE_DAYLIGHT_CCT_K, &grid)?;
        let n = grid.len();
        let weights = (0..k)
            .map(|c| {
                let row: Vec<f64> = (0..n)
                    .map(|l| projector.matrix[c * n + l] as f64 * daylight[l])
                    .collect();
                let white: f64 = row.iter().sum();
                row.iter().map(|w| w / white).collect()
            })
            .collect();
        Ok(HueSphere { weights, grid })
    }

    /// Number of classes.
    pub fn k(&self) -> usize {
        self.weights.len()
    }

    /// A uniformly drawn hue: unit length, orthogonal to `(1, …, 1)`.
    pub fn random_hue<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<f64> {
        loop {
            let mut d: Vec<f64> = (0..self.k()).map(|_| rng.sample(StandardNormal)).collect();
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            d.iter_mut().for_each(|v| *v -= mean);
            let norm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 1e-9 {
                d.iter_mut().for_each(|v| *v /= norm);
                return d;
            }
        }
    }

    /// The optimal reflectance of hue `d`: 1 where `d·F̃(λ) > 0`, else 0.
    pub fn reflectance(&self, hue: &[f64]) -> Vec<f64> {
        assert_eq!(hue.len(), self.k(), "HueSphere::reflectance: hue length");
        (0..self.grid.len())
            .map(|l| {
                let s: f64 = hue.iter().zip(&self.weights).map(|(d, w)| d * w[l]).sum();
                if s > 0.0 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// The colour of `reflectance` (white-normalised excitations, module docs).
    pub fn colour(&self, reflectance: &[f64]) -> Vec<f64> {
        assert_eq!(
            reflectance.len(),
            self.grid.len(),
            "HueSphere::colour: reflectance length"
        );
        self.weights
            .iter()
            .map(|w| w.iter().zip(reflectance).map(|(a, b)| a * b).sum())
            .collect()
    }

    /// `count` optimal reflectances of uniformly drawn hues (the support-point rule).
    pub fn library<R: Rng + ?Sized>(&self, count: usize, rng: &mut R) -> ReflectanceLibrary {
        let spectra = (0..count)
            .map(|_| self.reflectance(&self.random_hue(rng)))
            .collect();
        ReflectanceLibrary {
            grid: self.grid.clone(),
            spectra,
        }
    }

    /// `count` reflectances of uniformly drawn hues, each made a colour by `rule`. Error when
    /// the max basis cannot be built ([`max_chroma::MaxChromaHues::new`]).
    pub fn library_by<R: Rng + ?Sized>(
        &self,
        rule: HueRule,
        count: usize,
        rng: &mut R,
    ) -> Result<ReflectanceLibrary> {
        let spectra = match rule {
            HueRule::SupportPoint => return Ok(self.library(count, rng)),
            HueRule::MaxChroma => {
                let hues = max_chroma::MaxChromaHues::new(self)?;
                (0..count)
                    .map(|_| hues.reflectance(&self.random_hue(rng)))
                    .collect()
            }
        };
        Ok(ReflectanceLibrary {
            grid: self.grid.clone(),
            spectra,
        })
    }
}

#[cfg(test)]
#[path = "hue_sphere/tests.rs"]
mod tests;
