//! The settings of a scene pool: where its tiles come from, how many and how large, and how
//! spectral and RGB sources become cone excitations ([`super::ScenePool`]).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::scene::band_stack::BandStackOptions;
use crate::scene::dead_leaves::DeadLeavesConfig;
use crate::scene::hue_sphere::HueRule;
use crate::scene::mat_io::MatOptions;
use crate::scene::prepared::FileScale;
use crate::scene::q_from_lms::QFromLms;
use crate::scene::surfaces::SurfacesConfig;
use crate::scene::tetra::TetraEnvironment;

/// How RGB photographs become cone excitations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RgbPath {
    /// Spectra through the simulated display (paper).
    Display,
    /// The linear sRGB → cone matrix (official).
    Matrix,
}

/// The synthetic natural scenes a pool draws when it has no files.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SceneGenerator {
    /// Classic dead leaves ([`crate::scene::dead_leaves`]): an independent reflectance per leaf, leaves
    /// down to 1.5 px. A config that names no generator (every record made before
    /// [`SceneGenerator::Surfaces`] existed) reads back as this one.
    #[default]
    DeadLeaves,
    /// Surfaces matched to photographs' spatial statistics ([`crate::scene::surfaces`]).
    Surfaces,
}

/// Tetrachromatic augmentation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TetraMix {
    /// Which environment.
    pub environment: TetraEnvironment,
    /// Fraction of tiles drawn from it.
    pub fraction: f64,
    /// How the hue sphere's hues become colours (`HueSphere` only; default: the support point).
    #[serde(default, skip_serializing_if = "HueRule::is_default")]
    pub hue_rule: HueRule,
}

/// Pool settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenePoolConfig {
    /// Number of tiles.
    pub tiles: usize,
    /// Tile side, px (≥ field + 2·max shift).
    pub tile_px: usize,
    /// Which synthetic natural scenes the tiles hold.
    #[serde(default)]
    pub generator: SceneGenerator,
    /// Dead-leaves settings (`size_px` is replaced by `tile_px`).
    pub dead_leaves: DeadLeavesConfig,
    /// Surface-scene settings ([`SceneGenerator::Surfaces`]).
    #[serde(default)]
    pub surfaces: SurfacesConfig,
    /// Tetrachromatic augmentation (`None`: natural scenes only).
    pub tetra: Option<TetraMix>,
    /// Scene files, folders and glob patterns (`data/ARAD_1K_*.mat`); when non-empty they
    /// replace the synthetic scenes.
    pub files: Vec<PathBuf>,
    /// RGB photograph path.
    pub rgb_path: RgbPath,
    /// Per-image white balance of spectral sources.
    pub white_balance: bool,
    /// A control: every tile's Q plane replaced by its fixed affine least-squares prediction
    /// from L, M and S, before or after the white balance ([`crate::scene::q_from_lms`];
    /// `None`, the default: scenes as drawn).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_from_lms: Option<QFromLms>,
    /// Replace one tile every this many batches (0 = never).
    pub refresh_every_batches: usize,
    /// How scene files are scaled when prepared (default: short side = `tile_px`).
    #[serde(default)]
    pub file_scale: FileScale,
    /// Dataset names of `.mat` / HDF5 cubes (default: ARAD_1K's `cube` and `bands`).
    #[serde(default)]
    pub mat: MatOptions,
    /// Wavelengths of band-stack folders (default: CAVE's, 400 nm every 10 nm).
    #[serde(default)]
    pub band_stack: BandStackOptions,
    /// Folder of prepared scene files (default: `$XDG_CACHE_HOME/colorvision/scenes`, else
    /// `~/.cache/colorvision/scenes`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cache_dir: Option<PathBuf>,
}
