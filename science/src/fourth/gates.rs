//! Gate 1 of a fourth-cone-class experiment: Q's own signal through a real eye, before any
//! cortex (`colorvision experiment fourth-gates`). Evaluation of the data: it reads the scenes'
//! true excitations at the cones.
//!
//! For one eye (a [`RetinaConfig`]) and one [`GateCase`] (cone set, scenes, white balance, the
//! Q-replacement control) it draws `tiles` scene tiles, one field crop each, and at every cone at
//! least [`GATE_BORDER_CELLS`] from the lattice edge takes the true excitations of L, M, S and of
//! the fourth kind (`Q`: the mosaic row that is neither pure L, M nor S — a pure Q cone, or for
//! the span control `LMS+M_coexpress_L` the co-expressing ½L + ½M). Then:
//! - **own share** within and across tiles ([`super::own_signal`]), held out;
//! - **photon noise** at the Q cones, cone units², averaged over the eye's noise ratios:
//!   `σ² = scale² · E[r²] · mean a` with `a` the Q cones' activation (`retina::cones`), set
//!   against the within- and across-tile residual variances;
//! - **ONS own / noise**: in the optic nerve signal at the Q cones, the variance that Q's own
//!   part (its across-tile residual, at the Q cones only, through the lateral inhibition) adds,
//!   over the variance of the photon and LI noise there (measured at r = 1, times E\[r²\]);
//! - **demosaicking error**: at each Q cone, the across-tile fit of Q applied to L, M, S taken
//!   as the mean of the nearest pure cones of each class (the smallest square window, radius
//!   1–[`DEMOSAIC_MAX_RADIUS_CELLS`] cells, holding one), minus the same fit applied to the true
//!   L, M, S there: how well neighbouring cones tell what Q's own part must be told apart from
//!   (noise-free; cone units²).
//!
//! Held-out: the across fit and the ratios use the second half of the tiles only.

use std::time::Instant;

use crate::fourth::own_signal::{own_share, q_from_lms, OwnShare, TileSites};
use crate::Error;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use retina::config::RetinaConfig;
use retina::scene::hue_sphere::HueRule;
use retina::scene::pool::TetraMix;
use retina::scene::q_from_lms::QFromLms;
use retina::scene::tetra::TetraEnvironment;
use retina::{BatchTruth, Retina, SharedTile};
use serde::Serialize;

/// Cones this close to the lattice edge are left out (the lateral inhibition's edge), cells.
pub const GATE_BORDER_CELLS: usize = 6;
/// Largest window radius searched for a neighbouring cone of each class, cells.
pub const DEMOSAIC_MAX_RADIUS_CELLS: usize = 4;

/// The scenes of a gate (paper S-07's environments, pure or as trained).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GateScenes {
    /// Natural surface scenes (the preset's generator).
    Natural,
    /// Every tile from the observer's hue sphere.
    HueSphere,
    /// Every tile idealised (each class drawn freely).
    Idealised,
    /// Natural scenes with a tenth of the tiles from the hue sphere (as trained).
    NaturalHueSphereTenth,
    /// Natural scenes with a tenth of the tiles idealised (as trained).
    NaturalIdealisedTenth,
    /// Natural scenes with half of the tiles from the hue sphere.
    NaturalHueSphereHalf,
    /// Every tile from the hue sphere, its colours by [`HueRule::MaxChroma`].
    HueSphereMaxChroma,
    /// Natural scenes with a tenth of the tiles from the hue sphere by [`HueRule::MaxChroma`].
    NaturalHueSphereMaxChromaTenth,
    /// Natural scenes with half of the tiles idealised.
    NaturalIdealisedHalf,
}

impl GateScenes {
    /// Every source, in table order.
    pub const ALL: [GateScenes; 9] = [
        GateScenes::Natural,
        GateScenes::HueSphere,
        GateScenes::Idealised,
        GateScenes::NaturalHueSphereTenth,
        GateScenes::NaturalIdealisedTenth,
        GateScenes::NaturalHueSphereHalf,
        GateScenes::HueSphereMaxChroma,
        GateScenes::NaturalHueSphereMaxChromaTenth,
        GateScenes::NaturalIdealisedHalf,
    ];

    /// A short name.
    pub fn name(self) -> &'static str {
        match self {
            GateScenes::Natural => "natural",
            GateScenes::HueSphere => "hue-sphere tiles",
            GateScenes::Idealised => "idealised tiles",
            GateScenes::NaturalHueSphereTenth => "natural + 10 % hue-sphere",
            GateScenes::NaturalIdealisedTenth => "natural + 10 % idealised",
            GateScenes::NaturalHueSphereHalf => "natural + 50 % hue-sphere",
            GateScenes::HueSphereMaxChroma => "hue-sphere tiles (max chroma)",
            GateScenes::NaturalHueSphereMaxChromaTenth => "natural + 10 % hue-sphere (max chroma)",
            GateScenes::NaturalIdealisedHalf => "natural + 50 % idealised",
        }
    }

    /// The pool's tetrachromatic mix.
    pub fn tetra(self) -> Option<TetraMix> {
        let mix = |environment, fraction| {
            Some(TetraMix {
                environment,
                fraction,
                hue_rule: HueRule::SupportPoint,
            })
        };
        let max_chroma = |fraction| {
            Some(TetraMix {
                environment: TetraEnvironment::HueSphere,
                fraction,
                hue_rule: HueRule::MaxChroma,
            })
        };
        match self {
            GateScenes::Natural => None,
            GateScenes::HueSphere => mix(TetraEnvironment::HueSphere, 1.0),
            GateScenes::Idealised => mix(TetraEnvironment::Idealised, 1.0),
            GateScenes::NaturalHueSphereTenth => mix(TetraEnvironment::HueSphere, 0.1),
            GateScenes::NaturalIdealisedTenth => mix(TetraEnvironment::Idealised, 0.1),
            GateScenes::NaturalHueSphereHalf => mix(TetraEnvironment::HueSphere, 0.5),
            GateScenes::HueSphereMaxChroma => max_chroma(1.0),
            GateScenes::NaturalHueSphereMaxChromaTenth => max_chroma(0.1),
            GateScenes::NaturalIdealisedHalf => mix(TetraEnvironment::Idealised, 0.5),
        }
    }

    /// Tiles drawn: twice as many for a mix of a tenth, so both halves hold some of its rare
    /// tiles.
    pub fn tiles(self, base: usize) -> usize {
        match self {
            GateScenes::NaturalHueSphereTenth
            | GateScenes::NaturalIdealisedTenth
            | GateScenes::NaturalHueSphereMaxChromaTenth => 2 * base,
            _ => base,
        }
    }
}

/// One gate: cone set, scenes, white balance and the Q-replacement control.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GateCase {
    /// `--cones`.
    pub cones: String,
    /// The scenes.
    pub scenes: GateScenes,
    /// Per-image white balance on.
    pub white_balance: bool,
    /// Q replaced by its fixed fit from L, M, S (`retina::scene::q_from_lms`).
    pub q_from_lms: Option<QFromLms>,
}

/// The cone sets of the gates: pigeon Q, human Q, and a fourth kind in the span of L, M, S.
pub const GATE_CONES: [&str; 3] = ["LMSQ,Q:506", "LMSQ", "LMS+M_coexpress_L"];

/// Every case of the gates' table: each cone set × scenes × balance, then the pigeon-Q
/// controls (Q replaced before and after the balance) in natural scenes and the two mixes.
pub fn gate_cases() -> Vec<GateCase> {
    let mut cases = Vec::new();
    for cones in GATE_CONES {
        for scenes in GateScenes::ALL {
            for white_balance in [true, false] {
                cases.push(GateCase {
                    cones: cones.into(),
                    scenes,
                    white_balance,
                    q_from_lms: None,
                });
            }
        }
    }
    for scenes in [
        GateScenes::Natural,
        GateScenes::NaturalHueSphereTenth,
        GateScenes::NaturalIdealisedTenth,
    ] {
        for stage in [QFromLms::BeforeBalance, QFromLms::AfterBalance] {
            cases.push(GateCase {
                cones: GATE_CONES[0].into(),
                scenes,
                white_balance: true,
                q_from_lms: Some(stage),
            });
        }
    }
    cases
}

/// One row of the gates' table (module docs).
#[derive(Clone, Debug, Serialize)]
pub struct GateRow {
    /// The eye's preset name.
    pub eye: String,
    /// Cones per side.
    pub cones_per_side: usize,
    /// The case.
    pub case: GateCase,
    /// Tiles drawn.
    pub tiles: usize,
    /// Q's own share (within, across) and its size.
    pub own: OwnShare,
    /// Photon noise variance at the Q cones, cone units² (module docs).
    pub photon_noise_var: f64,
    /// In the ONS at the Q cones: Q's own part's variance over the noise's.
    pub ons_own_over_noise: f64,
    /// Demosaicking error variance at the Q cones, cone units².
    pub demosaic_var: f64,
    /// Wall time, s.
    pub seconds: f64,
}

/// What one held-out tile adds to the noise and demosaicking sums (at its Q cones).
#[derive(Default)]
struct QConeSums {
    cones: usize,
    activation: f64,
    demosaic_sq: f64,
    ons_own_sq: f64,
    ons_noise_sq: f64,
}

/// Gate 1 of `case` through `eye`, from `base_tiles` tiles ([`GateScenes::tiles`]) drawn from
/// `seed` (module docs).
pub fn measure_gate(
    eye: &RetinaConfig,
    case: &GateCase,
    base_tiles: usize,
    seed: u64,
) -> Result<GateRow, Error> {
    let start = Instant::now();
    let mut config = eye.clone();
    config.cones = case.cones.clone();
    config.scenes.tiles = case.scenes.tiles(base_tiles);
    config.scenes.tetra = case.scenes.tetra();
    config.scenes.white_balance = case.white_balance;
    config.scenes.q_from_lms = case.q_from_lms;
    config.scenes.refresh_every_batches = 0;
    config.scene_seed = seed;
    let retina = Retina::new(config)?;
    let kinds = Kinds::of(&retina)?;
    let mut rng = StdRng::seed_from_u64(seed);
    let crops: Vec<([i32; 2], Vec<f32>)> = (0..retina.pool.len())
        .map(|t| excitations(&retina, t, &mut rng))
        .collect();
    let tiles: Vec<TileSites> = crops.iter().map(|(_, e)| kinds.sites(e, &retina)).collect();
    let own = own_share(&tiles);
    let half = tiles.len() / 2;
    let fit = q_from_lms(&tiles[..half].concat());
    let mut sums = QConeSums::default();
    for (t, (origin, e)) in crops.iter().enumerate().skip(half) {
        kinds.add_q_cone_sums(&retina, t, *origin, e, &fit, &mut rng, &mut sums);
    }
    let noise = &retina.config.noise;
    let r2 = mean_r_squared(noise);
    let per = sums.cones.max(1) as f64;
    Ok(GateRow {
        eye: eye.name.clone(),
        cones_per_side: eye.cones_per_side,
        case: case.clone(),
        tiles: tiles.len(),
        own,
        photon_noise_var: (noise.photon_noise_scale as f64).powi(2) * r2 * sums.activation / per,
        ons_own_over_noise: sums.ons_own_sq / (r2 * sums.ons_noise_sq),
        demosaic_var: sums.demosaic_sq / per,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// `E[r²]` over the eye's noise ratios `r = k / levels`, k uniform in {0, …, levels}.
pub fn mean_r_squared(noise: &retina::cones::NoiseConfig) -> f64 {
    if !noise.enabled || noise.noise_levels == 0 {
        return 0.0;
    }
    let l = noise.noise_levels as f64;
    (0..=noise.noise_levels)
        .map(|k| (k as f64 / l).powi(2))
        .sum::<f64>()
        / (l + 1.0)
}

/// One field crop of tile `t` at a random origin: the origin and the excitations of every class
/// at every cone, `(k, n, n)`.
fn excitations(retina: &Retina, t: usize, rng: &mut StdRng) -> ([i32; 2], Vec<f32>) {
    let c = &retina.config;
    let m = c.eye_motion.max_shift_px;
    let hi = c.scenes.tile_px as i32 - c.field_px as i32 - m;
    let origin = [rng.random_range(m..=hi), rng.random_range(m..=hi)];
    let truth = BatchTruth {
        oracle_shift_px: vec![[0, 0]],
        oracle_shift_normalised: vec![[0.0, 0.0]],
        noise_ratio: 0.0,
        tiles: vec![t],
        origins_px: vec![origin],
        stacks: vec![SharedTile(retina.pool.shared_tile(t))],
    };
    (origin, retina.class_excitations_at_cones(&truth, 0))
}

mod kinds;
pub mod table;
use kinds::Kinds;

#[cfg(test)]
mod tests;
