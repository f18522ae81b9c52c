//! A pool of pre-generated scene tiles that training crops are drawn from.
//!
//! Stage `ScenePool::new(config, projection, levels, rng)`:
//! - output: `tiles` square tiles of `tile_px`, each projected ONCE onto the mosaic's classes
//!   (plus the reference L, M, S for ground truth), white-balanced where the official code
//!   does, and filtered into a full-resolution mip stack ([`MipStack`], `(levels, planes, tile,
//!   tile)`). A training sample picks a tile and a field origin inside it; an integer eye shift
//!   moves the origin.
//!
//! Sources, in order of precedence:
//! 1. `files` — files, folders and glob patterns ([`super::sources`]) of spectral OpenEXR
//!    (`.exr`), MATLAB v7.3 / HDF5 cubes (`.mat`, `.h5`; NTIRE 2022 / ARAD_1K), folders of one
//!    PNG per band (CAVE) and RGB
//!    photographs (`.png`, through the simulated display or the official matrix, `rgb_path`),
//!    [`super::prepared`] once for the eye — projected, short side resized to `tile_px`, white
//!    balanced per image — and kept in an on-disk cache (`cache_dir`), not in memory. Each tile
//!    is a random square crop of one file's planes; tile draws walk the files in an order
//!    shuffled once from the pool's seed (initial tiles first, then each refresh), so every
//!    file is used before any is used again.
//! 2. otherwise synthetic scenes of the pool's `generator` — surfaces ([`super::surfaces`]) or
//!    the classic dead leaves ([`super::dead_leaves`]) — with a fraction
//!    `tetra.fraction` of tiles from a tetrachromatic environment ([`super::tetra`]; the
//!    paper's 100 patches on 900 images is 0.1).
//!
//! White balance (authors' code, docs/references.md#scenes, per image and per plane: divide by the maximum, multiply
//! by the class's response to the sRGB white) is applied to spectral sources — dead leaves and
//! tetra environments per tile, EXR and `.mat` files per whole image at preparation — when
//! `white_balance` is on (the default). RGB photographs are not balanced: their white is already
//! the sRGB white (the official RGB path has no balance).
//!
//! `refresh_every_batches` > 0 replaces one tile (round robin) every that many batches, so long
//! runs see fresh scenes at a small amortised cost.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

mod settings;

use super::dead_leaves::{DeadLeavesConfig, LeafScene};
use super::hue_sphere::HueSphere;
use super::library::ReflectanceLibrary;
use super::prepared::PreparedScenes;
pub use super::prepared::{FileScale, ProgressFn, SceneProgress};
pub use super::projection::SceneProjection;
use super::q_from_lms::{QFromLms, QFromLmsFit, Q_FIT_SEED, Q_FIT_TILES};
use super::rgb::Display;
use super::surfaces::surface_scene;
use super::tetra::{
    idealised_class_planes, optimal_colour_library, patch_config, TetraEnvironment,
    OPTIMAL_LIBRARY_SIZE,
};
use super::ClassPlanes;
use crate::error::{Result, RetinaError};
use crate::foveation::MipStack;
pub use settings::{RgbPath, SceneGenerator, ScenePoolConfig, TetraMix};

/// Bilinear resize of `(planes, h, w)` data to `(planes, nh, nw)` (align-corners mapping).
pub fn resize_bilinear(
    data: &[f32],
    planes: usize,
    h: usize,
    w: usize,
    nh: usize,
    nw: usize,
) -> Vec<f32> {
    let mut out = vec![0.0f32; planes * nh * nw];
    let sy = if nh > 1 {
        (h - 1) as f32 / (nh - 1) as f32
    } else {
        0.0
    };
    let sx = if nw > 1 {
        (w - 1) as f32 / (nw - 1) as f32
    } else {
        0.0
    };
    for p in 0..planes {
        let src = &data[p * h * w..(p + 1) * h * w];
        for y in 0..nh {
            let fy = y as f32 * sy;
            let y0 = (fy.floor() as usize).min(h.saturating_sub(2));
            let ty = fy - y0 as f32;
            let y1 = (y0 + 1).min(h - 1);
            for x in 0..nw {
                let fx = x as f32 * sx;
                let x0 = (fx.floor() as usize).min(w.saturating_sub(2));
                let tx = fx - x0 as f32;
                let x1 = (x0 + 1).min(w - 1);
                let top = src[y0 * w + x0] * (1.0 - tx) + src[y0 * w + x1] * tx;
                let bot = src[y1 * w + x0] * (1.0 - tx) + src[y1 * w + x1] * tx;
                out[p * nh * nw + y * nw + x] = top * (1.0 - ty) + bot * ty;
            }
        }
    }
    out
}

/// Random `size × size` crop of `(planes, h, w)` data, upscaling first if it is smaller.
fn random_crop<R: Rng + ?Sized>(
    data: &[f32],
    planes: usize,
    h: usize,
    w: usize,
    size: usize,
    rng: &mut R,
) -> Vec<f32> {
    let (data, h, w) = if h < size || w < size {
        let s = size as f64 / h.min(w) as f64;
        let (nh, nw) = (
            ((h as f64 * s).ceil() as usize).max(size),
            ((w as f64 * s).ceil() as usize).max(size),
        );
        (resize_bilinear(data, planes, h, w, nh, nw), nh, nw)
    } else {
        (data.to_vec(), h, w)
    };
    let (y0, x0) = (
        rng.random_range(0..=h - size),
        rng.random_range(0..=w - size),
    );
    let mut out = Vec::with_capacity(planes * size * size);
    for p in 0..planes {
        for y in 0..size {
            let row = p * h * w + (y0 + y) * w + x0;
            out.extend_from_slice(&data[row..row + size]);
        }
    }
    out
}

/// Tiles and everything needed to make more.
pub struct ScenePool {
    /// Settings.
    pub config: ScenePoolConfig,
    /// The projection onto the mosaic.
    pub projection: SceneProjection,
    /// Mip levels per tile.
    pub levels: usize,
    /// Shared, so that a batch's truth keeps the tile it was cut from after a refresh.
    tiles: Vec<Arc<MipStack>>,
    library: ReflectanceLibrary,
    /// Surfaces of the tetrachromatic patches: the observer's hue sphere or optimal colours.
    patch_library: ReflectanceLibrary,
    files: Option<PreparedScenes>,
    /// The order tile draws walk the files in (a permutation drawn once).
    file_order: Vec<usize>,
    next_refresh: usize,
    /// The Q plane's replacement, when `config.q_from_lms` asks for one.
    q_fit: Option<QFromLmsFit>,
}

impl std::fmt::Debug for ScenePool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScenePool")
            .field("tiles", &self.tiles.len())
            .field("tile_px", &self.config.tile_px)
            .field("levels", &self.levels)
            .finish()
    }
}

impl ScenePool {
    /// Prepare the files, then make `config.tiles` tiles in parallel (each from its own seed
    /// drawn from `rng`). Errors: unreadable files, scene grids not covering the sensitivities.
    pub fn new<R: Rng + ?Sized>(
        config: ScenePoolConfig,
        projection: SceneProjection,
        levels: usize,
        rng: &mut R,
    ) -> Result<ScenePool> {
        Self::with_progress(config, projection, levels, rng, &|_| {})
    }

    /// [`ScenePool::new`], telling `progress` of each scene file prepared.
    pub fn with_progress<R: Rng + ?Sized>(
        config: ScenePoolConfig,
        projection: SceneProjection,
        levels: usize,
        rng: &mut R,
        progress: ProgressFn<'_>,
    ) -> Result<ScenePool> {
        let never = AtomicBool::new(false);
        Self::with_progress_until(config, projection, levels, rng, progress, &never)
    }

    /// [`ScenePool::with_progress`] that ends with [`RetinaError::Stopped`] once `stop` is set
    /// (checked before every tile is drawn).
    pub fn with_progress_until<R: Rng + ?Sized>(
        config: ScenePoolConfig,
        projection: SceneProjection,
        levels: usize,
        rng: &mut R,
        progress: ProgressFn<'_>,
        stop: &AtomicBool,
    ) -> Result<ScenePool> {
        if config.tiles == 0 || config.tile_px < 2 {
            return Err(RetinaError::setting(
                "scenes",
                format!("{} tiles of {} px", config.tiles, config.tile_px),
            ));
        }
        let grid = projection.grid.clone();
        let display = match config.rgb_path {
            RgbPath::Display => Some(Display::srgb_like(&grid)?),
            RgbPath::Matrix => None,
        };
        let (files, file_order) = if config.files.is_empty() {
            (None, vec![])
        } else {
            let prepared =
                PreparedScenes::prepare(&config, &projection, display.as_ref(), progress)?;
            let mut order: Vec<usize> = (0..prepared.len()).collect();
            order.shuffle(rng);
            (Some(prepared), order)
        };
        let mut patch_rng = StdRng::seed_from_u64(rng.random());
        let patch_library = match config.tetra {
            Some(t) if t.environment == TetraEnvironment::HueSphere => HueSphere::new(
                &projection.projector,
                projection.k,
            )?
            .library_by(t.hue_rule, OPTIMAL_LIBRARY_SIZE, &mut patch_rng)?,
            _ => optimal_colour_library(&grid, OPTIMAL_LIBRARY_SIZE, &mut patch_rng),
        };
        let mut pool = ScenePool {
            library: ReflectanceLibrary::measured(&grid)?,
            patch_library,
            config,
            projection,
            levels,
            tiles: vec![],
            files,
            file_order,
            next_refresh: 0,
            q_fit: None,
        };
        pool.q_fit = pool.fit_q_from_lms()?;
        let seeds: Vec<u64> = (0..pool.config.tiles).map(|_| rng.random()).collect();
        let tiles = seeds
            .par_iter()
            .enumerate()
            .map(|(i, &s)| {
                if stop.load(Ordering::Relaxed) {
                    return Err(RetinaError::Stopped);
                }
                pool.make_tile(i, &mut StdRng::seed_from_u64(s))
                    .map(Arc::new)
            })
            .collect::<Result<Vec<_>>>()?;
        pool.tiles = tiles;
        Ok(pool)
    }

    /// The scene file tile draw number `draw` crops (module docs), if the pool has files.
    pub fn file_for_draw(&self, draw: usize) -> Option<&Path> {
        let files = self.files.as_ref()?;
        let i = self.file_order[draw % self.file_order.len()];
        Some(&files.scenes[i].source)
    }

    /// Make the class planes of tile draw number `index`: the initial tiles are draws
    /// `0..tiles`, each refresh the next draw (module docs); white balanced, and the Q plane
    /// replaced where `q_from_lms` asks ([`super::q_from_lms`]).
    pub fn make_planes<R: Rng + ?Sized>(&self, index: usize, rng: &mut R) -> Result<ClassPlanes> {
        let (mut planes, balance) = self.draw_planes(index, rng)?;
        let replace = |stage: QFromLms, planes: &mut ClassPlanes| {
            if let Some(fit) = self.q_fit.as_ref().filter(|f| f.stage == stage) {
                fit.replace(planes);
            }
        };
        replace(QFromLms::BeforeBalance, &mut planes);
        if balance && self.config.white_balance {
            planes.white_balance(&self.projection.white);
        }
        replace(QFromLms::AfterBalance, &mut planes);
        Ok(planes)
    }

    /// The fixed replacement of the Q plane (`config.q_from_lms`), fitted on [`Q_FIT_TILES`]
    /// tiles drawn from [`Q_FIT_SEED`] at the stage it applies at; `None` when unset. Error for
    /// an eye without a class named Q, or a replacement before the balance of scene files
    /// (balanced when they are prepared).
    fn fit_q_from_lms(&self) -> Result<Option<QFromLmsFit>> {
        let Some(stage) = self.config.q_from_lms else {
            return Ok(None);
        };
        let proj = &self.projection;
        let q_plane = proj.plane_classes[..proj.k]
            .iter()
            .position(|c| c.name == "Q")
            .ok_or_else(|| {
                RetinaError::setting(
                    "scenes.q_from_lms",
                    "the eye has no cone class named Q whose plane could be replaced",
                )
            })?;
        if stage == QFromLms::BeforeBalance && self.files.is_some() {
            return Err(RetinaError::setting(
                "scenes.q_from_lms",
                "`before_balance` needs synthetic scenes: scene files are balanced when prepared",
            ));
        }
        let mut rng = StdRng::seed_from_u64(Q_FIT_SEED);
        let tiles = (0..Q_FIT_TILES)
            .map(|i| {
                let (mut planes, balance) = self.draw_planes(i, &mut rng)?;
                if stage == QFromLms::AfterBalance && balance && self.config.white_balance {
                    planes.white_balance(&proj.white);
                }
                Ok(planes)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Some(QFromLmsFit::fit(
            stage,
            &tiles,
            q_plane,
            proj.reference_lms,
        )))
    }

    /// The fitted replacement of the Q plane, if the pool has one.
    pub fn q_from_lms_fit(&self) -> Option<&QFromLmsFit> {
        self.q_fit.as_ref()
    }

    /// The class planes of draw `index` as drawn, and whether they are to be white balanced.
    fn draw_planes<R: Rng + ?Sized>(
        &self,
        index: usize,
        rng: &mut R,
    ) -> Result<(ClassPlanes, bool)> {
        let size = self.config.tile_px;
        let proj = &self.projection;
        let (planes, balance) = if let Some(files) = &self.files {
            // Prepared planes are white balanced already (per image, not per crop).
            let p = files.planes(self.file_order[index % self.file_order.len()], proj)?;
            let data = random_crop(&p.planes, p.n_planes, p.h, p.w, size, rng);
            (proj.wrap(size, size, data), false)
        } else {
            let tetra = self
                .config
                .tetra
                .filter(|t| rng.random::<f64>() < t.fraction);
            match tetra {
                None => {
                    let scene = match self.config.generator {
                        SceneGenerator::DeadLeaves => {
                            let cfg = DeadLeavesConfig {
                                size_px: size,
                                ..self.config.dead_leaves.clone()
                            };
                            LeafScene::generate(&cfg, &self.library, rng)?
                        }
                        SceneGenerator::Surfaces => {
                            surface_scene(&self.config.surfaces, &self.library, size, rng)?
                        }
                    };
                    (
                        proj.wrap(
                            size,
                            size,
                            scene.render_projected(&self.library, &proj.projector),
                        ),
                        true,
                    )
                }
                Some(t) => {
                    let scene = LeafScene::generate(&patch_config(size), &self.patch_library, rng)?;
                    let data = match t.environment {
                        TetraEnvironment::OptimalColours | TetraEnvironment::HueSphere => {
                            scene.render_projected(&self.patch_library, &proj.projector)
                        }
                        TetraEnvironment::Idealised => {
                            // Mosaic classes get independent values; appended reference
                            // planes copy the mosaic's L/M/S-named planes where they exist.
                            let mut d = idealised_class_planes(&scene, proj.k, rng);
                            let nn = size * size;
                            for p in proj.k..proj.n_planes() {
                                let name = proj.plane_classes[p].name.trim_start_matches("ref_");
                                let src = proj.plane_classes[..proj.k]
                                    .iter()
                                    .position(|c| c.name == name);
                                match src {
                                    Some(s) => d.extend_from_within(s * nn..(s + 1) * nn),
                                    None => d.extend(std::iter::repeat_n(0.0, nn)),
                                }
                            }
                            d
                        }
                    };
                    (proj.wrap(size, size, data), true)
                }
            }
        };
        Ok((planes, balance))
    }

    fn make_tile<R: Rng + ?Sized>(&self, index: usize, rng: &mut R) -> Result<MipStack> {
        let p = self.make_planes(index, rng)?;
        Ok(MipStack::compute(
            &p.planes,
            p.n_planes,
            p.h,
            p.w,
            self.levels,
        ))
    }

    /// Replace the next tile (round robin) with a fresh one, from the next draw.
    pub fn refresh_one<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<()> {
        let i = self.next_refresh % self.tiles.len();
        self.tiles[i] = Arc::new(self.make_tile(self.tiles.len() + self.next_refresh, rng)?);
        self.next_refresh += 1;
        Ok(())
    }

    /// Number of tiles.
    pub fn len(&self) -> usize {
        self.tiles.len()
    }

    /// Always false after construction.
    pub fn is_empty(&self) -> bool {
        self.tiles.is_empty()
    }

    /// Tile `i`.
    pub fn tile(&self, i: usize) -> &MipStack {
        &self.tiles[i]
    }

    /// Tile `i`, shared: it stays what it is when a refresh replaces slot `i`.
    pub fn shared_tile(&self, i: usize) -> Arc<MipStack> {
        Arc::clone(&self.tiles[i])
    }
}
