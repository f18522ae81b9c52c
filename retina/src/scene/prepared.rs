//! Scene files prepared once for an eye, as the authors prepare NTIRE 2022 / ARAD_1K (authors'
//! code, docs/references.md#scenes), and kept on disk instead of in memory.
//!
//! Per file ([`super::sources`] expands folders and patterns), in parallel:
//! 1. read: spectral OpenEXR, MATLAB v7.3 / HDF5 and ENVI cubes and band-stack folders are checked
//!    (finite, ≥ 0) and resampled onto the eye's wavelength grid ([`super::SpectralImage::resample`]);
//!    PNG photographs are decoded to linear sRGB;
//! 2. projected onto the eye's planes (the mosaic's classes and the reference L, M, S,
//!    [`SceneProjection`]): spectra through the cone sensitivities, photographs through the
//!    simulated display or the official matrix ([`RgbPath`]);
//! 3. resized ([`super::resize`]) so the short side is the pool's `tile_px` (ARAD's 482 × 512
//!    becomes 542 × 576 for a 542-px tile, the authors' field 512 + 2 × 15 px of eye motion;
//!    192 × 204 for the quick eye's 192-px tile), or with [`FileScale::Native`] kept as it is
//!    unless smaller than a tile;
//! 4. white balanced per image, spectral sources only, when `white_balance` is on (each plane
//!    divided by its maximum over the image and multiplied by its response to the sRGB white,
//!    [`ClassPlanes::white_balance`]); photographs are not (their white is already sRGB's);
//! 5. written to the [`PlaneCache`] under a key of the file's content and of everything above
//!    (grid, classes, sensitivities, tile size, scale mode, balance, RGB path, `.mat` names,
//!    band-stack wavelengths; a band stack's content is that of all its band files, an ENVI
//!    cube's that of its header and cube file), or
//!    found there: a second run with the same eye reads no cube.
//!
//! Memory holds one cube per worker thread while preparing, and afterwards only the list of
//! entries: a tile reads its image's planes from the cache ([`PreparedScenes::planes`]).
//! Progress is reported through a callback after each file ([`SceneProgress`]); any error
//! names the file, and stops the preparation of the files not yet started.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::band_stack::{band_files, read_scene_band_stack};
use super::envi_io::{cube_file, read_scene_envi};
use super::exr_io::read_scene_exr;
use super::mat_io::read_scene_mat;
use super::plane_cache::{default_dir, CachedPlanes, PlaneCache};
#[cfg(doc)]
use super::pool::RgbPath;
use super::pool::ScenePoolConfig;
use super::projection::SceneProjection;
use super::resize::{resize, short_side_size};
use super::rgb::{class_planes_by_matrix, Display, RgbImage};
use super::sources::{expand, SceneFormat};
use super::ClassPlanes;
use crate::error::{Result, RetinaError};

/// How scene files are scaled at preparation (module docs, step 3).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FileScale {
    /// Short side = the pool's `tile_px` (the authors' preprocessing: one photograph is about
    /// one field plus the eye-motion margin).
    #[default]
    Tile,
    /// Native resolution; only an image smaller than a tile is enlarged to fit one.
    Native,
}

/// Progress of the preparation: `done` of `total` files finished, the last being `path`.
#[derive(Debug, Clone, Copy)]
pub struct SceneProgress<'a> {
    /// Files finished.
    pub done: usize,
    /// Files in all.
    pub total: usize,
    /// The file just finished.
    pub path: &'a Path,
    /// Whether its planes came from the cache (no cube read).
    pub from_cache: bool,
}

/// A callback told of each finished file (from worker threads).
pub type ProgressFn<'a> = &'a (dyn Fn(&SceneProgress<'_>) + Sync);

/// One prepared file: where its planes are and their size.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PreparedScene {
    /// The scene file.
    pub source: PathBuf,
    /// Its cache key.
    pub key: String,
    /// Rows of the prepared planes.
    pub h: usize,
    /// Columns of the prepared planes.
    pub w: usize,
}

/// The prepared files of a pool (module docs).
#[derive(Debug, Clone)]
pub struct PreparedScenes {
    cache: PlaneCache,
    /// One entry per file, in the order the files were named.
    pub scenes: Vec<PreparedScene>,
}

/// What shapes a file's planes, shared by every file.
struct Context<'a> {
    config: &'a ScenePoolConfig,
    projection: &'a SceneProjection,
    display: Option<&'a Display>,
    cache: &'a PlaneCache,
}

impl PreparedScenes {
    /// Prepare every file of `config.files` (module docs). `display` is the simulated display
    /// of the [`RgbPath::Display`] path (`None`: photographs go through the official matrix).
    pub fn prepare(
        config: &ScenePoolConfig,
        projection: &SceneProjection,
        display: Option<&Display>,
        progress: ProgressFn<'_>,
    ) -> Result<PreparedScenes> {
        let files = expand(&config.files)?;
        let dir = match &config.cache_dir {
            Some(d) => d.clone(),
            None => default_dir()?,
        };
        let cache = PlaneCache::open(dir)?;
        let ctx = Context {
            config,
            projection,
            display,
            cache: &cache,
        };
        let (done, failed) = (AtomicUsize::new(0), AtomicBool::new(false));
        let results: Vec<Option<Result<PreparedScene>>> = files
            .par_iter()
            .map(|path| {
                if failed.load(Ordering::Relaxed) {
                    return None;
                }
                let r = prepare_one(path, &ctx);
                match &r {
                    Ok((_, from_cache)) => progress(&SceneProgress {
                        done: done.fetch_add(1, Ordering::Relaxed) + 1,
                        total: files.len(),
                        path,
                        from_cache: *from_cache,
                    }),
                    Err(_) => failed.store(true, Ordering::Relaxed),
                }
                Some(r.map(|(s, _)| s))
            })
            .collect();
        // The first failure in the files' order, so the message does not depend on timing.
        if let Some(e) = results.iter().position(|r| matches!(r, Some(Err(_)))) {
            return Err(results.into_iter().nth(e).flatten().unwrap().unwrap_err());
        }
        let scenes = results.into_iter().map(|r| r.unwrap().unwrap()).collect();
        Ok(PreparedScenes { cache, scenes })
    }

    /// Number of files.
    pub fn len(&self) -> usize {
        self.scenes.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.scenes.is_empty()
    }

    /// The prepared planes of file `i`, read from the cache.
    pub fn planes(&self, i: usize, projection: &SceneProjection) -> Result<ClassPlanes> {
        let p = self.cache.read(&self.scenes[i].key)?;
        let shape_ok = p.n_planes == projection.n_planes()
            && (p.h, p.w) == (self.scenes[i].h, self.scenes[i].w);
        if !shape_ok {
            return Err(crate::error::RetinaError::scene_file(
                self.cache.planes_path(&self.scenes[i].key),
                "a prepared-scene cache entry changed during the run; delete it and run again",
            ));
        }
        Ok(projection.wrap(p.h, p.w, p.data))
    }
}

/// A description of everything that shapes the planes of a file of `format` (module docs).
fn settings(ctx: &Context<'_>, format: SceneFormat) -> Vec<u8> {
    let (c, p) = (ctx.config, ctx.projection);
    let mut s = format!(
        "grid {:?}\nclasses {:?}\nmatrix {:?}\nwhite {:?}\ntile {}\nscale {:?}\n",
        p.grid.as_slice(),
        p.plane_classes,
        p.projector.matrix,
        p.white,
        c.tile_px,
        c.file_scale
    );
    match format {
        SceneFormat::Exr => s += &format!("exr\nbalance {}\n", c.white_balance),
        SceneFormat::Envi => s += &format!("envi\nbalance {}\n", c.white_balance),
        SceneFormat::Mat => s += &format!("mat {:?}\nbalance {}\n", c.mat, c.white_balance),
        SceneFormat::BandStack => {
            s += &format!("stack {:?}\nbalance {}\n", c.band_stack, c.white_balance)
        }
        SceneFormat::Png => s += &format!("png {:?}\n", c.rgb_path),
    }
    s.into_bytes()
}

/// Prepare one file, or find it in the cache: its entry, and whether it came from the cache.
fn prepare_one(path: &Path, ctx: &Context<'_>) -> Result<(PreparedScene, bool)> {
    let format = SceneFormat::of(path).expect("sources::expand keeps scene files only");
    let content = match format {
        SceneFormat::BandStack => ctx
            .cache
            .content_hash_all(&band_files(path).unwrap_or_default())?,
        SceneFormat::Envi => ctx
            .cache
            .content_hash_all(&[path.into(), cube_file(path)?])?,
        _ => ctx.cache.content_hash(path)?,
    };
    let key = PlaneCache::key(&content, &settings(ctx, format));
    let entry = |h, w| PreparedScene {
        source: path.to_path_buf(),
        key: key.clone(),
        h,
        w,
    };
    if let Some((n, h, w)) = ctx.cache.entry_shape(&key) {
        if n == ctx.projection.n_planes() {
            return Ok((entry(h, w), true));
        }
    }
    let mut planes = read_planes(path, format, ctx)?;
    check_finite(path, &planes, ctx.projection, "")?;
    let (nh, nw) = match ctx.config.file_scale {
        FileScale::Tile => short_side_size(planes.h, planes.w, ctx.config.tile_px),
        FileScale::Native if planes.h.min(planes.w) < ctx.config.tile_px => {
            short_side_size(planes.h, planes.w, ctx.config.tile_px)
        }
        FileScale::Native => (planes.h, planes.w),
    };
    let data = resize(&planes.planes, planes.n_planes, planes.h, planes.w, nh, nw);
    planes = ctx.projection.wrap(nh, nw, data);
    if format != SceneFormat::Png && ctx.config.white_balance {
        planes.white_balance(&ctx.projection.white);
    }
    check_finite(
        path,
        &planes,
        ctx.projection,
        " once resized and white balanced",
    )?;
    let cached = CachedPlanes {
        n_planes: planes.n_planes,
        h: nh,
        w: nw,
        data: planes.planes,
    };
    ctx.cache.write(&key, &cached)?;
    Ok((entry(nh, nw), false))
}

/// Refuses planes holding a value that is not finite, naming the file, the pixel (`at` says of
/// which image: the file's own, or the prepared one) and the cone class: radiance that is
/// finite in the file can still overflow `f32` once summed over wavelengths (values near 3e38),
/// and would reach training as NaN.
fn check_finite(
    path: &Path,
    planes: &ClassPlanes,
    projection: &SceneProjection,
    at: &str,
) -> Result<()> {
    let Some((p, x, y, v)) = planes.first_non_finite() else {
        return Ok(());
    };
    let class = projection
        .plane_classes
        .get(p)
        .map_or_else(|| format!("plane {p}"), |c| format!("class {}", c.name));
    let largest = planes
        .planes
        .iter()
        .filter(|v| v.is_finite())
        .fold(0f32, |m, v| m.max(v.abs()));
    Err(RetinaError::Radiance {
        path: path.to_path_buf(),
        message: format!(
            "pixel (x {x}, y {y}){at}: the cone excitation of {class} is {v} (the largest finite \
             one is {largest:e}): the radiance is too large to sum in 32-bit floats; scale the \
             scene's values down"
        ),
    })
}

/// A file's planes at its own resolution (module docs, steps 1–2).
fn read_planes(path: &Path, format: SceneFormat, ctx: &Context<'_>) -> Result<ClassPlanes> {
    let proj = ctx.projection;
    Ok(match format {
        SceneFormat::Exr => proj.project(&read_scene_exr(path, &proj.grid)?),
        SceneFormat::Envi => proj.project(&read_scene_envi(path, &proj.grid)?),
        SceneFormat::Mat => proj.project(&read_scene_mat(path, &ctx.config.mat, &proj.grid)?),
        SceneFormat::BandStack => proj.project(&read_scene_band_stack(
            path,
            &ctx.config.band_stack,
            &proj.grid,
        )?),
        SceneFormat::Png => {
            let rgb = RgbImage::read_png(path)?;
            match ctx.display {
                Some(d) => proj.project(&d.spectral_image(&rgb)),
                None => proj.wrap(rgb.h, rgb.w, class_planes_by_matrix(&rgb, &proj.cone_rgb)),
            }
        }
    })
}

#[cfg(test)]
mod tests;
