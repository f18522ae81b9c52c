//! Retina configuration and its presets.
//!
//! Every number is a field here (or in the stage configs it holds), with its unit in its name
//! and its source in the stage's docs. Presets are named sets of values:
//!
//! | preset | cones | field | layout | LI | max shift | tiles × px | notes |
//! |---|---|---|---|---|---|---|---|
//! | `tiny` | 32² | 64 px | foveated | yes | 2 px = 1 cone | 8 × 96 | tests, seconds |
//! | `quick` | 64² | 128 px | foveated | yes | 15 px = 7.5 cones | 32 × 192 | the default CPU run |
//! | `sandbox` | 64² | 64 px | identity | no | 5 px = 5 cones | 32 × 96 | official sandbox (MSS 5) |
//! | `paper` | 256² | 512 px | foveated | yes | 15 px = 7.5 cones | 8 × 576 | official everything |
//!
//! Field sizes keep the official ratio of 2 field px per cone for foveated layouts (authors'
//! code, docs/references.md#foveation: 256 cones sample a 512-px field); the maximum shift is the official one in cone
//! spacings, 7.5 ([`EyeMotionConfig::official_for`]), except on the 32-cone test eye
//! ([`RetinaConfig::tiny`]). Scenes are synthetic dead leaves by default.

use colorimetry::{ConeTemplate, WavelengthGrid};
use serde::{Deserialize, Serialize};

use crate::cones::NoiseConfig;
use crate::error::{Result, RetinaError};
use crate::eye_motion::EyeMotionConfig;
use crate::foveation::{FoveationConfig, LayoutConfig};
use crate::lateral_inhibition::DogConfig;
use crate::scene::dead_leaves::DeadLeavesConfig;
use crate::scene::pool::{RgbPath, SceneGenerator, ScenePoolConfig};
use crate::scene::surfaces::SurfacesConfig;
use crate::scene::tetra::TetraEnvironment;
use crate::spikes::LifConfig;

/// A uniform wavelength grid, nm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridConfig {
    /// First wavelength, nm.
    pub start_nm: f64,
    /// Last wavelength, nm.
    pub end_nm: f64,
    /// Step, nm.
    pub step_nm: f64,
}

impl Default for GridConfig {
    /// 400–700 nm every 10 nm (the NTIRE bands).
    fn default() -> Self {
        GridConfig {
            start_nm: 400.0,
            end_nm: 700.0,
            step_nm: 10.0,
        }
    }
}

impl GridConfig {
    /// The grid.
    pub fn grid(&self) -> Result<WavelengthGrid> {
        Ok(WavelengthGrid::range(
            self.start_nm,
            self.end_nm,
            self.step_nm,
        )?)
    }
}

/// Everything that defines a simulated eye.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RetinaConfig {
    /// Preset name this came from (informational).
    pub name: String,
    /// Cones per side of the lattice (the ONS is n × n).
    pub cones_per_side: usize,
    /// Side of the scene field the cones sample, px.
    pub field_px: usize,
    /// Mosaic specification (`LMS`, `LMSQ,Q:506`, `MS+L_coexpress_M`, …; see `mosaic`).
    pub cones: String,
    /// Seed of the mosaic (official: 0).
    pub mosaic_seed: u64,
    /// Cone positions.
    pub layout: LayoutConfig,
    /// Seed of the positional jitter (official: torch seed 0).
    pub layout_seed: u64,
    /// Wavelength grid of spectra and sensitivities.
    pub grid: GridConfig,
    /// Cone template.
    pub template: ConeTemplate,
    /// Eye motion.
    pub eye_motion: EyeMotionConfig,
    /// Photon and LI noise.
    pub noise: NoiseConfig,
    /// Lateral inhibition (`None`: the cone activations are the ONS, as in the sandbox).
    pub lateral_inhibition: Option<DogConfig>,
    /// LIF settings of the optional spiking path.
    pub lif: LifConfig,
    /// Scene pool.
    pub scenes: ScenePoolConfig,
    /// Seed of the scene pool.
    pub scene_seed: u64,
}

fn pool(tiles: usize, tile_px: usize, refresh_every_batches: usize) -> ScenePoolConfig {
    ScenePoolConfig {
        tiles,
        tile_px,
        generator: SceneGenerator::DeadLeaves,
        dead_leaves: DeadLeavesConfig::default(),
        surfaces: SurfacesConfig::default(),
        tetra: None,
        files: vec![],
        rgb_path: RgbPath::Display,
        white_balance: true,
        q_from_lms: None,
        refresh_every_batches,
        file_scale: Default::default(),
        mat: Default::default(),
        band_stack: Default::default(),
        cache_dir: None,
    }
}

impl RetinaConfig {
    fn foveated(
        name: &str,
        n: usize,
        field_px: usize,
        tiles: usize,
        tile_px: usize,
        refresh: usize,
    ) -> Self {
        RetinaConfig {
            name: name.into(),
            cones_per_side: n,
            field_px,
            cones: "LMS".into(),
            mosaic_seed: 0,
            layout: LayoutConfig::Foveated(FoveationConfig::default()),
            layout_seed: 0,
            grid: GridConfig::default(),
            template: ConeTemplate::default(),
            eye_motion: EyeMotionConfig::official_for(field_px, n),
            noise: NoiseConfig::default(),
            lateral_inhibition: Some(DogConfig::default()),
            lif: LifConfig::default(),
            scenes: pool(tiles, tile_px, refresh),
            scene_seed: 1234,
        }
    }

    /// 32² cones, for tests. The one eye that does not shift by the official 7.5 cones: on a
    /// 32-cone field that is 23 % of the field per axis, and a tiny LM cortex then measured
    /// 1-D after 6 000 steps (C's L/M d′ 1.6) where with 1-cone shifts it measures 2-D after
    /// 1 500. It shifts by 1 cone spacing (2 px).
    pub fn tiny() -> Self {
        RetinaConfig {
            eye_motion: EyeMotionConfig { max_shift_px: 2 },
            ..Self::foveated("tiny", 32, 64, 8, 96, 0)
        }
    }

    /// The same eye in surface scenes ([`SceneGenerator::Surfaces`]), whose colour stays
    /// coherent over several cones as a photograph's does; the eyes that stand in for the
    /// paper's (`quick`, `large`, `paper`) see these. In the classic dead leaves, whose colour
    /// changes at the scale of single cones, the quick eye's cortex stayed 2-D at 12 000 steps
    /// where in surfaces it was 3-D (docs/notebook/2026-11-28-why-colour-emerged-slowly.md).
    /// `tiny` and `sandbox` keep the classic leaves, on which their tests' known answers were
    /// measured.
    fn in_surfaces(mut self) -> Self {
        self.scenes.generator = SceneGenerator::Surfaces;
        self
    }

    /// 64² cones, full pipeline (foveation + LI): the default CPU run.
    pub fn quick() -> Self {
        Self::foveated("quick", 64, 128, 32, 192, 32).in_surfaces()
    }

    /// 128² cones in a 256-px field: the quick eye's field sampled twice as finely per axis,
    /// between `quick` and `paper`. Four times the cones in each CMF-SIM patch let a narrow
    /// dimension clear the instrument's threshold: the oracle decoder's best three primaries
    /// fail by 16.4× the threshold for LMS + human Q through this eye, 5.8× through `quick`,
    /// 20.2× through `paper` (docs/notebook/2026-11-27-why-rows-differ-from-the-paper.md). Its
    /// tiles are 320 px (the field and 2 × 15 px of eye motion, rounded up to a multiple of
    /// 64); 16 of them hold 1.6 M pixels, about the quick pool's 32 × 192² (1.2 M).
    pub fn large() -> Self {
        Self::foveated("large", 128, 256, 16, 320, 32).in_surfaces()
    }

    /// The official sandbox: 64² cones on a 64-px field, identity layout, no LI, shift 5 px.
    pub fn sandbox() -> Self {
        RetinaConfig {
            name: "sandbox".into(),
            field_px: 64,
            layout: LayoutConfig::Identity,
            eye_motion: EyeMotionConfig { max_shift_px: 5 },
            lateral_inhibition: None,
            scenes: pool(32, 96, 32),
            ..Self::foveated("sandbox", 64, 64, 32, 96, 32)
        }
    }

    /// 256² cones in a 512-px field, official everything.
    pub fn paper() -> Self {
        Self::foveated("paper", 256, 512, 8, 576, 16).in_surfaces()
    }

    /// A preset by name: `tiny`, `quick`, `large`, `sandbox`, `paper`.
    pub fn preset(name: &str) -> Result<Self> {
        match name {
            "tiny" => Ok(Self::tiny()),
            "quick" => Ok(Self::quick()),
            "large" => Ok(Self::large()),
            "sandbox" => Ok(Self::sandbox()),
            "paper" => Ok(Self::paper()),
            _ => Err(RetinaError::setting(
                "preset",
                format!("`{name}` is not tiny, quick, large, sandbox or paper"),
            )),
        }
    }

    /// Check the values that must agree with each other.
    pub fn validate(&self) -> Result<()> {
        let n = self.cones_per_side;
        if n < 2 {
            return Err(RetinaError::setting("cones_per_side", format!("{n} < 2")));
        }
        if matches!(self.layout, LayoutConfig::Identity) && self.field_px != n {
            return Err(RetinaError::setting(
                "field_px",
                format!(
                    "identity layout needs field_px = cones_per_side ({} vs {n})",
                    self.field_px
                ),
            ));
        }
        if self.field_px < 2 {
            return Err(RetinaError::setting(
                "field_px",
                format!("{} < 2", self.field_px),
            ));
        }
        if self.eye_motion.max_shift_px < 1 {
            return Err(RetinaError::setting(
                "eye_motion.max_shift_px",
                "must be ≥ 1",
            ));
        }
        if n > MAX_CONES_PER_SIDE || self.field_px > MAX_FIELD_PX {
            return Err(RetinaError::setting(
                "cones_per_side / field_px",
                format!(
                    "{n} cones and a {} px field; the limits are {MAX_CONES_PER_SIDE} and \
                     {MAX_FIELD_PX}",
                    self.field_px
                ),
            ));
        }
        self.validate_stages()?;
        self.validate_grid_coverage()?;
        let need = self.field_px + 2 * self.eye_motion.max_shift_px as usize;
        if self.scenes.tile_px < need {
            return Err(RetinaError::setting(
                "scenes.tile_px",
                format!(
                    "{} px is smaller than field + 2·max shift = {need} px",
                    self.scenes.tile_px
                ),
            ));
        }
        Ok(())
    }

    /// Checks the tetrachromatic environment: a fraction of tiles, and a hue sphere only for an
    /// eye with at least two classes.
    fn validate_tetra(&self) -> Result<()> {
        if self.scenes.q_from_lms.is_some() {
            let spec = crate::mosaic::MosaicSpec::parse(&self.cones)?;
            if !spec.class_names().iter().any(|c| c.as_str() == "Q") {
                return Err(RetinaError::setting(
                    "scenes.q_from_lms",
                    format!(
                        "`{}` has no Q class whose plane could be replaced",
                        self.cones
                    ),
                ));
            }
        }
        if let Some(t) = &self.scenes.tetra {
            if !(t.fraction.is_finite() && (0.0..=1.0).contains(&t.fraction)) {
                return Err(RetinaError::setting(
                    "scenes.tetra.fraction",
                    format!("{} must be a fraction of tiles in [0, 1]", t.fraction),
                ));
            }
            let classes = crate::mosaic::MosaicSpec::parse(&self.cones)?
                .class_names()
                .len();
            if t.environment != TetraEnvironment::HueSphere && !t.hue_rule.is_default() {
                return Err(RetinaError::setting(
                    "scenes.tetra.hue_rule",
                    format!(
                        "{:?} chooses hue-sphere colours; the environment is {:?}",
                        t.hue_rule, t.environment
                    ),
                ));
            }
            if t.environment == TetraEnvironment::HueSphere && classes < 2 {
                return Err(RetinaError::setting(
                    "scenes.tetra.environment",
                    format!(
                        "`{}` has {classes} cone class; a hue sphere needs at least two",
                        self.cones
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Checks the stage settings that would otherwise panic or allocate without bound.
    fn validate_stages(&self) -> Result<()> {
        let n = self.cones_per_side;
        if let Some(li) = &self.lateral_inhibition {
            for (name, sigma) in [
                (
                    "lateral_inhibition.sigma_centre_cells",
                    li.sigma_centre_cells,
                ),
                (
                    "lateral_inhibition.sigma_surround_cells",
                    li.sigma_surround_cells,
                ),
            ] {
                // The kernel spans 6σ; it must fit the lattice.
                if !(sigma.is_finite() && sigma > 0.0 && 6.0 * sigma <= n as f64) {
                    return Err(RetinaError::setting(
                        name,
                        format!("{sigma} must be positive and at most n/6 = {:.3} cells (the 6σ kernel must fit the {n}×{n} lattice)", n as f64 / 6.0),
                    ));
                }
            }
            if !li.surround_weight.is_finite() {
                return Err(RetinaError::setting(
                    "lateral_inhibition.surround_weight",
                    format!("{} must be finite", li.surround_weight),
                ));
            }
        }
        self.validate_tetra()?;
        if self.scenes.dead_leaves.max_leaves == 0 {
            return Err(RetinaError::setting(
                "scenes.dead_leaves.max_leaves",
                "must be at least 1",
            ));
        }
        if let LayoutConfig::Foveated(f) = &self.layout {
            if let Some(j) = &f.jitter {
                let lattice = crate::foveation::layout::JITTER_LATTICE_OVERSIZE * n;
                let finest = u32::try_from(j.octaves.saturating_sub(1))
                    .ok()
                    .and_then(|o| j.base_resolution.checked_shl(o))
                    .filter(|&r| r >> j.octaves.saturating_sub(1) == j.base_resolution);
                if j.base_resolution == 0 || finest.is_none_or(|r| r > lattice) {
                    return Err(RetinaError::setting(
                        "layout.Foveated.jitter.base_resolution",
                        format!(
                            "{} with {} octaves: must be ≥ 1, and base_resolution·2^(octaves−1) \
                             at most the {lattice}-cell noise lattice",
                            j.base_resolution, j.octaves
                        ),
                    ));
                }
                if !(j.persistence.is_finite() && j.amplitude_cells.is_finite()) {
                    return Err(RetinaError::setting(
                        "layout.Foveated.jitter",
                        "persistence and amplitude_cells must be finite",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Largest cone lattice side accepted (the paper uses 256).
pub const MAX_CONES_PER_SIDE: usize = 2048;

/// Largest scene field side accepted, px (the paper uses 512).
pub const MAX_FIELD_PX: usize = 8192;

mod grid_coverage;
