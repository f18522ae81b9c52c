//! Environments rich in tetrachromatic colours (paper S-07).
//!
//! The paper augments its natural images with colour patches of two kinds: colours from the
//! observer's tetrachromatic hue sphere (Lee et al. 2024), and "idealised" colours where each
//! cone channel may take any value — the theoretical maximum of chromatic contrast. Neither set
//! is released (authors' code, docs/references.md#scenes). Ours:
//! - [`TetraEnvironment::HueSphere`]: dead-leaves patches of the observer's own hue-sphere
//!   colours ([`super::hue_sphere`]): for uniformly drawn hues, the surface that goes furthest
//!   in that hue for this observer's classes, rendered under the usual daylights.
//! - [`TetraEnvironment::Idealised`]: dead-leaves patches whose class excitations are drawn
//!   independently and uniformly in [0, 1] per class and per patch (then shaded like any leaf).
//!   This lives in class space — no spectrum produces it — exactly as the paper's third
//!   environment.
//! - [`TetraEnvironment::OptimalColours`]: dead-leaves patches of spectrally saturated surfaces:
//!   MacAdam-type optimal reflectances (1 inside a wavelength band, 0 outside, or the reverse),
//!   with logistic edges 5 nm wide, under the usual daylights. They are the most saturated
//!   surface colours for any observer, so they sample the boundary of its colour solid, but
//!   not evenly in any one observer's hues (the same set for every observer).
//!
//! Patches are larger than natural leaves (radius 4–30 % of the scene side) so each colour
//! covers many cones.

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::dead_leaves::{DeadLeavesConfig, LeafScene};
use super::library::ReflectanceLibrary;
use colorimetry::WavelengthGrid;

/// Width of the logistic edges of optimal reflectances, nm.
pub const OPTIMAL_EDGE_WIDTH_NM: f64 = 5.0;
/// Number of optimal reflectances in a generated library.
pub const OPTIMAL_LIBRARY_SIZE: usize = 2000;
/// Smallest patch radius as a fraction of the scene side.
pub const PATCH_RADIUS_MIN_FRACTION: f64 = 0.04;

/// Which tetrachromatic environment (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TetraEnvironment {
    /// The observer's hue-sphere colours ([`super::hue_sphere`]).
    HueSphere,
    /// Independent uniform class excitations per patch.
    Idealised,
    /// Spectrally saturated (optimal) surfaces.
    OptimalColours,
}

impl TetraEnvironment {
    /// What the environment's patches are, in words (for run logs).
    pub fn describe(self) -> &'static str {
        match self {
            TetraEnvironment::HueSphere => {
                "surfaces of the most saturated colour the eye's cone classes see in each hue \
                 (its hue sphere)"
            }
            TetraEnvironment::Idealised => "idealised colours, each cone class excited freely",
            TetraEnvironment::OptimalColours => "spectrally saturated (optimal) surfaces",
        }
    }
}

/// Dead-leaves settings for colour patches in a `size_px` scene.
pub fn patch_config(size_px: usize) -> DeadLeavesConfig {
    DeadLeavesConfig {
        size_px,
        radius_min_px: (PATCH_RADIUS_MIN_FRACTION * size_px as f64).max(2.0),
        radius_max_fraction: 0.3,
        ..DeadLeavesConfig::default()
    }
}

/// `count` optimal reflectances on `grid` (module docs): band-pass or band-stop with edges at
/// uniformly drawn wavelengths.
pub fn optimal_colour_library<R: Rng + ?Sized>(
    grid: &WavelengthGrid,
    count: usize,
    rng: &mut R,
) -> ReflectanceLibrary {
    let (lo, hi) = (grid.min_nm(), grid.max_nm());
    let logistic = |x: f64| 1.0 / (1.0 + (-x / (OPTIMAL_EDGE_WIDTH_NM / 4.0)).exp());
    let spectra = (0..count)
        .map(|_| {
            let a = lo + (hi - lo) * rng.random::<f64>();
            let b = lo + (hi - lo) * rng.random::<f64>();
            let (a, b) = (a.min(b), a.max(b));
            let stop = rng.random::<bool>();
            grid.as_slice()
                .iter()
                .map(|&l| {
                    let pass = logistic(l - a) * logistic(b - l);
                    if stop {
                        1.0 - pass
                    } else {
                        pass
                    }
                })
                .collect()
        })
        .collect();
    ReflectanceLibrary {
        grid: grid.clone(),
        spectra,
    }
}

/// Class planes `(k, n, n)` of an idealised scene: each leaf of `scene` gets k independent
/// uniform values, times the pixel's shading.
pub fn idealised_class_planes<R: Rng + ?Sized>(
    scene: &LeafScene,
    k: usize,
    rng: &mut R,
) -> Vec<f32> {
    let values: Vec<f32> = (0..scene.n_leaves() * k)
        .map(|_| rng.random::<f32>())
        .collect();
    let nn = scene.size_px * scene.size_px;
    let mut out = vec![0.0f32; k * nn];
    for p in 0..nn {
        let leaf = scene.label[p] as usize;
        for c in 0..k {
            out[c * nn + p] = scene.shading[p] * values[leaf * k + c];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::tests::{lms_plus, q_over_l_contrast};
    use crate::scene::Projector;
    use colorimetry::{sensitivities, ConeClass, ConeTemplate};
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    #[test]
    fn tetra_environments_have_more_q_versus_l_contrast_than_natural_scenes() {
        let g = WavelengthGrid::default();
        let classes = lms_plus(ConeClass::human_q());
        let f = sensitivities(&classes, &ConeTemplate::default(), &g).unwrap();
        let proj = Projector::cones(&f);
        let mut rng = StdRng::seed_from_u64(2);
        let n = 128;
        let nn = n * n;
        let natural_lib = ReflectanceLibrary::measured(&g).unwrap();
        let natural_cfg = DeadLeavesConfig {
            size_px: n,
            ..DeadLeavesConfig::default()
        };
        let nat = LeafScene::generate(&natural_cfg, &natural_lib, &mut rng).unwrap();
        let r_nat = q_over_l_contrast(&nat.render_projected(&natural_lib, &proj), nn);
        let opt_lib = optimal_colour_library(&g, OPTIMAL_LIBRARY_SIZE, &mut rng);
        let opt = LeafScene::generate(&patch_config(n), &opt_lib, &mut rng).unwrap();
        let r_opt = q_over_l_contrast(&opt.render_projected(&opt_lib, &proj), nn);
        let ideal = idealised_class_planes(&opt, 4, &mut rng);
        let r_ideal = q_over_l_contrast(&ideal, nn);
        eprintln!(
            "std ln(Q/L): natural {r_nat:.4}, optimal colours {r_opt:.4}, idealised {r_ideal:.4}"
        );
        assert!(
            r_nat < r_opt && r_opt < r_ideal,
            "{r_nat} {r_opt} {r_ideal}"
        );
        assert!(opt_lib
            .spectra
            .iter()
            .flatten()
            .all(|&v| (0.0..=1.0).contains(&v)));
    }
}
