//! The whole eye: scene tile → eye motion → cone sampling → photon noise → lateral inhibition →
//! optic nerve signal (ONS), batched for training.
//!
//! Stage `Retina::batch(rng, batch_size) -> EyeBatch`, the signal ([`OnsBatch`], the one batch
//! type from eye to cortex) and the truth the eye keeps ([`BatchTruth`]):
//! - signal `ons`: `(B, 2, n, n)` row-major f32 — per sample, frame 0 and frame 1 (the field
//!   moved by the oracle shift), each the noisy bipolar (LI) signal on the cone lattice (the
//!   official training ONS; with LI off, the noisy cone activations). Values are dimensionless:
//!   cone excitations are ≈ 1 for the sRGB white after white balance, and the LI output of a
//!   uniform white field is ≈ 0.09 (the DoG's DC gain).
//! - truth `oracle_shift_px[b] = [dx, dy]`: frame 1 samples the scene at x + d (see `eye_motion`);
//!   `oracle_shift_normalised[b] = d / (field_px / 2)` (official units).
//! - the per-batch noise ratio r (official: one draw per batch), and for evaluation the tile and
//!   frame-0 field origin of each sample.
//!
//! Data flow per sample (authors' code, docs/references.md#retina-data-flow): pick a pool tile and a field origin with room for any
//! shift; for each frame, `Cones::compute` (weights · class planes, mip-mapped at the cone
//! positions), photon noise, LI, LI noise. Samples run in parallel (rayon); each sample has its
//! own RNG seeded from `rng`, so a batch is reproducible for a given `rng` state.
//!
//! Ground truth for evaluation only (the cortex never sees it): [`Retina::srgb_at_cones`]
//! (scene linear sRGB at each cone, from the reference L, M, S through the official matrix),
//! [`Retina::class_excitations_at_cones`], the mosaic (`retina.mosaic`: true classes and
//! weights), positions (`retina.layout`), and the DoG kernel ([`Retina::dog_kernel`]).

use colorimetry::{sensitivities, ConeFundamentals};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use crate::cones::{add_photon_noise, Cones};
use crate::config::RetinaConfig;
use crate::error::Result;
use crate::eye_motion::normalise_shift;
use crate::foveation::{ConeLayout, ConeSampler, MipStack};
use crate::lateral_inhibition::{add_multiplicative_noise, LateralInhibition};
use crate::mosaic::Mosaic;
use crate::scene::pool::{ProgressFn, ScenePool, SceneProjection};
use crate::scene::{ClassPlanes, SpectralImage};
pub use optic_nerve::OnsBatch;

/// The ground truth of one batch, which the eye keeps (module docs): evaluation and pictures
/// read it; the cortex never receives it (the run's source copies the normalised shift into the
/// signal only when a run asks for oracle motion).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchTruth {
    /// Per sample `[dx, dy]`, field px.
    pub oracle_shift_px: Vec<[i32; 2]>,
    /// Per sample `d / (field_px / 2)`.
    pub oracle_shift_normalised: Vec<[f32; 2]>,
    /// The batch's noise ratio r.
    pub noise_ratio: f32,
    /// Pool tile of each sample (its slot in the pool when the batch was drawn).
    pub tiles: Vec<usize>,
    /// Frame-0 field origin `[x, y]` in its tile, px.
    pub origins_px: Vec<[i32; 2]>,
    /// The tile each sample was cut from, kept: the truth readers
    /// ([`Retina::class_excitations_at_cones`], [`Retina::srgb_at_cones`]) read these, so a
    /// batch's truth stays its own after later batches refresh the pool's slots.
    pub stacks: Vec<SharedTile>,
}

/// A scene tile shared between the pool and the batches cut from it (compared by content,
/// printed by its shape).
#[derive(Clone)]
pub struct SharedTile(pub Arc<MipStack>);

impl PartialEq for SharedTile {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.0 == other.0
    }
}

impl std::fmt::Debug for SharedTile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "SharedTile({}×{}×{}×{})",
            self.0.levels, self.0.planes, self.0.h, self.0.w
        )
    }
}

/// One batch from the eye: the signal it sends and the truth it keeps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EyeBatch {
    /// The optic nerve signal, `oracle_motion` unset.
    pub signal: OnsBatch,
    /// Its ground truth.
    pub truth: BatchTruth,
}

/// The simulated eye (module docs).
pub struct Retina {
    /// The configuration it was built from.
    pub config: RetinaConfig,
    /// Cone classes and per-cell weights.
    pub mosaic: Mosaic,
    /// Cone positions in the field.
    pub layout: ConeLayout,
    /// Sensitivities of the mosaic's classes on the configured grid (peak 1).
    pub fundamentals: ConeFundamentals,
    /// Weights and sampling taps.
    pub cones: Cones,
    /// Lateral inhibition, if configured.
    pub lateral_inhibition: Option<LateralInhibition>,
    /// Scene tiles.
    pub pool: ScenePool,
    scratch: Vec<Vec<f32>>,
    batches_done: usize,
}

impl std::fmt::Debug for Retina {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Retina")
            .field("config", &self.config.name)
            .field("mosaic", &self.mosaic.spec_text)
            .field("n", &self.mosaic.n)
            .field("pool", &self.pool)
            .finish()
    }
}

impl Retina {
    /// Build the eye: mosaic, layout, sensitivities, LI and the scene pool.
    pub fn new(config: RetinaConfig) -> Result<Retina> {
        Self::with_progress(config, &|_| {})
    }

    /// [`Retina::new`], telling `progress` of each scene file prepared for the pool (a
    /// command-line program draws it as a bar; see [`crate::scene::prepared`]).
    pub fn with_progress(config: RetinaConfig, progress: ProgressFn<'_>) -> Result<Retina> {
        Self::with_progress_until(config, progress, &AtomicBool::new(false))
    }

    /// [`Retina::with_progress`] that ends with [`crate::RetinaError::Stopped`] once `stop` is
    /// set (checked before every scene tile is drawn).
    pub fn with_progress_until(
        config: RetinaConfig,
        progress: ProgressFn<'_>,
        stop: &AtomicBool,
    ) -> Result<Retina> {
        config.validate()?;
        let n = config.cones_per_side;
        let mosaic = Mosaic::from_spec_str(&config.cones, n, config.mosaic_seed)?;
        let layout = ConeLayout::compute(&config.layout, n, config.field_px, config.layout_seed);
        let grid = config.grid.grid()?;
        let fundamentals = sensitivities(&mosaic.classes, &config.template, &grid)?;
        let sampler = ConeSampler::compute(&layout);
        let levels = sampler.levels_needed();
        let cones = Cones::new(&mosaic, sampler);
        let lateral_inhibition = config
            .lateral_inhibition
            .map(|c| LateralInhibition::new(c, n));
        let projection = SceneProjection::new(&mosaic.classes, &config.template, &grid)?;
        let mut rng = SmallRng::seed_from_u64(config.scene_seed);
        let pool = ScenePool::with_progress_until(
            config.scenes.clone(),
            projection,
            levels,
            &mut rng,
            progress,
            stop,
        )?;
        Ok(Retina {
            config,
            mosaic,
            layout,
            fundamentals,
            cones,
            lateral_inhibition,
            pool,
            scratch: vec![],
            batches_done: 0,
        })
    }

    /// A preset with another mosaic (`tiny`/`quick`/`sandbox`/`paper`, e.g. `LMSQ,Q:506`).
    pub fn preset(name: &str, cones: &str) -> Result<Retina> {
        let mut c = RetinaConfig::preset(name)?;
        c.cones = cones.into();
        Retina::new(c)
    }

    /// Cones per side.
    pub fn n(&self) -> usize {
        self.mosaic.n
    }

    /// Noise-free encoding of one frame: class planes of `stack` sampled at the cones with the
    /// field's top-left at `origin`, then LI. `act` and `out` are `(n, n)` buffers.
    pub fn encode_frame(
        &self,
        stack: &MipStack,
        origin: [i32; 2],
        act: &mut [f32],
        out: &mut [f32],
    ) {
        self.cones.compute(stack, origin, act);
        match &self.lateral_inhibition {
            Some(li) => li.compute(act, out),
            None => out.copy_from_slice(act),
        }
    }

    /// [`Retina::encode_frame`] with the photon and LI noise of ratio `r`.
    pub fn encode_frame_noisy<R: Rng + ?Sized>(
        &self,
        rng: &mut R,
        r: f32,
        stack: &MipStack,
        origin: [i32; 2],
        act: &mut [f32],
        out: &mut [f32],
    ) {
        let noise = &self.config.noise;
        self.cones.compute(stack, origin, act);
        add_photon_noise(rng, act, noise.photon_noise_scale, r);
        match &self.lateral_inhibition {
            Some(li) => {
                li.compute(act, out);
                add_multiplicative_noise(rng, out, noise.li_noise_scale, r);
            }
            None => out.copy_from_slice(act),
        }
    }

    /// Project a spectral image onto the mosaic's classes (plus reference planes).
    pub fn project(&self, img: &SpectralImage) -> Result<ClassPlanes> {
        let on = img.resample(&self.pool.projection.grid, "scene")?;
        Ok(self.pool.projection.project(&on))
    }

    /// Noise-free ONS `(n, n)` of class planes at least `field_px` on each side, field at the
    /// top-left. Linear in the planes.
    pub fn encode_planes(&self, planes: &ClassPlanes) -> Vec<f32> {
        let stack = MipStack::compute(
            &planes.planes,
            planes.n_planes,
            planes.h,
            planes.w,
            self.pool.levels,
        );
        let nn = self.n() * self.n();
        let (mut act, mut out) = (vec![0.0; nn], vec![0.0; nn]);
        self.encode_frame(&stack, [0, 0], &mut act, &mut out);
        out
    }

    /// Noise-free ONS `(n, n)` of a spectral image (no white balance: linear in the scene).
    pub fn encode_spectral(&self, img: &SpectralImage) -> Result<Vec<f32>> {
        Ok(self.encode_planes(&self.project(img)?))
    }

    /// One batch of `batch_size` ONS pairs with its ground truth (module docs).
    pub fn batch<R: Rng + ?Sized>(&mut self, rng: &mut R, batch_size: usize) -> EyeBatch {
        let mut out = EyeBatch::default();
        self.batch_into(rng, batch_size, &mut out.signal, &mut out.truth);
        out
    }

    /// [`Retina::batch`] into reused buffers: the signal into `signal` (its `oracle_motion` set
    /// to `None`: the eye sends only the ONS), the ground truth into `truth`.
    pub fn batch_into<R: Rng + ?Sized>(
        &mut self,
        rng: &mut R,
        batch_size: usize,
        signal: &mut OnsBatch,
        truth: &mut BatchTruth,
    ) {
        self.skip_batch(rng);
        let n = self.n();
        let nn = n * n;
        let f = self.config.field_px as i32;
        let m = self.config.eye_motion.max_shift_px;
        let tile_px = self.config.scenes.tile_px as i32;
        signal.n = n;
        signal.batch = batch_size;
        signal.oracle_motion = None;
        signal.ons.resize(batch_size * 2 * nn, 0.0);
        let out = truth;
        out.noise_ratio = self.config.noise.draw_ratio(rng);
        out.oracle_shift_px.clear();
        out.tiles.clear();
        out.stacks.clear();
        out.origins_px.clear();
        let mut seeds = Vec::with_capacity(batch_size);
        for _ in 0..batch_size {
            let tile = rng.random_range(0..self.pool.len());
            out.tiles.push(tile);
            out.stacks.push(SharedTile(self.pool.shared_tile(tile)));
            let (lo, hi) = (m, tile_px - f - m);
            out.origins_px
                .push([rng.random_range(lo..=hi), rng.random_range(lo..=hi)]);
            out.oracle_shift_px
                .push(self.config.eye_motion.draw_shift(rng));
            seeds.push(rng.random::<u64>());
        }
        out.oracle_shift_normalised.clear();
        out.oracle_shift_normalised.extend(
            out.oracle_shift_px
                .iter()
                .map(|&d| normalise_shift(d, self.config.field_px)),
        );
        self.scratch.resize_with(batch_size, || vec![0.0; nn]);
        let r = out.noise_ratio;
        let mut scratch = std::mem::take(&mut self.scratch);
        let this = &*self;
        let out = &*out;
        signal
            .ons
            .par_chunks_mut(2 * nn)
            .zip(scratch.par_iter_mut())
            .enumerate()
            .for_each(|(b, (pair, act))| {
                act.resize(nn, 0.0);
                let mut srng = SmallRng::seed_from_u64(seeds[b]);
                let stack = &out.stacks[b].0;
                let o = out.origins_px[b];
                let d = out.oracle_shift_px[b];
                let (f0, f1) = pair.split_at_mut(nn);
                this.encode_frame_noisy(&mut srng, r, stack, o, act, f0);
                this.encode_frame_noisy(&mut srng, r, stack, [o[0] + d[0], o[1] + d[1]], act, f1);
            });
        self.scratch = scratch;
    }

    /// What drawing a batch with `rng` does to the eye's state, without drawing it: the scene
    /// pool replaces a tile when its `refresh_every_batches` comes round (seeded by the batch's
    /// first draw from `rng`), and the batch is counted ([`Retina::batch_into`] begins with
    /// this). For a caller that seeds each batch's RNG afresh (as `science`'s `RetinaSource`
    /// does) the next batch is then the one drawing this one would have left; `rng` itself is
    /// left where one draw leaves it, not where a whole batch would.
    pub fn skip_batch<R: Rng + ?Sized>(&mut self, rng: &mut R) {
        let refresh = self.config.scenes.refresh_every_batches;
        if refresh > 0 && self.batches_done > 0 && self.batches_done.is_multiple_of(refresh) {
            let mut r = SmallRng::seed_from_u64(rng.random());
            self.pool
                .refresh_one(&mut r)
                .expect("refreshing a tile of a pool that was built once cannot fail");
        }
        self.batches_done += 1;
    }

    /// Linear sRGB of the scene at each cone for frame `frame` of every sample of a batch:
    /// `(B, 3, n, n)` (evaluation only; from the reference L, M, S planes through the official
    /// LMS → linear sRGB matrix, noise-free, anti-aliased like the cones).
    pub fn srgb_at_cones(&self, batch: &BatchTruth, frame: usize) -> Vec<f32> {
        let proj = &self.pool.projection;
        let nn = self.n() * self.n();
        let samples = batch.stacks.len();
        let mut out = vec![0.0f32; samples * 3 * nn];
        let mut lms = vec![vec![0.0f32; nn]; 3];
        for b in 0..samples {
            let stack = &batch.stacks[b].0;
            let o = self.frame_origin(batch, b, frame);
            for (c, buf) in lms.iter_mut().enumerate() {
                self.cones
                    .sampler
                    .sample_plane(stack, proj.reference_lms[c], o, buf);
            }
            for r in 0..3 {
                let dst = &mut out[(b * 3 + r) * nn..(b * 3 + r + 1) * nn];
                for (i, v) in dst.iter_mut().enumerate() {
                    *v = (0..3)
                        .map(|c| lms[c][i] as f64 * proj.lms_to_rgb[c][r])
                        .sum::<f64>() as f32;
                }
            }
        }
        out
    }

    /// Excitation of every mosaic class at each cone (not weighted by the cone's own class),
    /// frame `frame`: `(B, k, n, n)` (evaluation only).
    pub fn class_excitations_at_cones(&self, batch: &BatchTruth, frame: usize) -> Vec<f32> {
        let (nn, k) = (self.n() * self.n(), self.mosaic.n_classes());
        let samples = batch.stacks.len();
        let mut out = vec![0.0f32; samples * k * nn];
        for b in 0..samples {
            let stack = &batch.stacks[b].0;
            let o = self.frame_origin(batch, b, frame);
            for c in 0..k {
                let dst = &mut out[(b * k + c) * nn..(b * k + c + 1) * nn];
                self.cones.sampler.sample_plane(stack, c, o, dst);
            }
        }
        out
    }

    fn frame_origin(&self, batch: &BatchTruth, b: usize, frame: usize) -> [i32; 2] {
        assert!(frame < 2, "Retina: frame {frame} of a pair");
        let (o, d) = (batch.origins_px[b], batch.oracle_shift_px[b]);
        [o[0] + frame as i32 * d[0], o[1] + frame as i32 * d[1]]
    }

    /// The true DoG kernel `(size, size)` and its side, if LI is on.
    pub fn dog_kernel(&self) -> Option<(&[f64], usize)> {
        self.lateral_inhibition
            .as_ref()
            .map(|li| (li.kernel.as_slice(), li.size))
    }
}

#[cfg(test)]
mod tests;
