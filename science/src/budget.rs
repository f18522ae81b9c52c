//! How much memory a run takes, estimated from its settings before anything is allocated, and
//! the limit it must stay under.
//!
//! Conventions: sizes in bytes (`_bytes`), said in MiB. The estimate is the peak resident
//! memory of the process: a fixed part (the program, its tables, the eye and the cortex per
//! cone), the scene pools (training and held-out, and the hidden-signal measures' stream of four
//! tiles at a run's end: every tile's mip stack of class planes), the hidden-signal measures'
//! held-out samples ([`held_out_bytes`]: `schedule.held_out_scenes` at a run's end), the
//! checkpoints `average` holds beside the one it measures, and the larger of a training step
//! (the autodiff tape of a batch) and, when CMF-SIM runs, a decode of the observer (each
//! thread's tape over `observer.decode_batch` shows); the two never overlap. The coefficients
//! are peak resident memory measured on the `tiny` and `quick` presets (2 threads;
//! `tests/memory_budget.rs` checks the estimate within ±30 % of the peak there, and
//! peak ≤ estimate ≤ 1.3 × peak where a setting makes a part grow).
//! Two parts that grow without bound at the tops of their ranges are modelled from their shapes
//! instead: P's flow parameters and their copies ([`flow`], `cortex.p.hidden`), and CMF-SIM's
//! shows, readouts, per-location cache and solver states ([`cmf_sim`], `cmf_sim.location_pairs`
//! × `cmf_sim.n_test_wavelengths` × `cmf_sim.max_primaries`), which CMF-SIM holds beside its
//! decodes.
//!
//! Five estimates: [`estimate`] for a run (training, and CMF-SIM of its cortex when it
//! measures; [`without_pictures`] for a run that draws none), [`estimate_cmf_sim`] for
//! `colorvision cmf-sim` of any observer (no training step; the search's buffers sized by that
//! observer's readout, the cortex's decodes only for the cortex), [`estimate_convergence`] for
//! `colorvision convergence` (a checkpoint's trainer, the held-out pool, no step),
//! [`estimate_average`] for `colorvision average` (that, with CMF-SIM, and the other
//! checkpoints held beside it) and [`estimate_eye`] for the commands that build the eye alone
//! (`simulate`, `gamut`: one scene pool).

use crate::config::RunConfig;
use crate::observer::ObserverKind;
use retina::foveation::{ConeLayout, ConeSampler};

pub mod cmf_sim;
pub mod flow;

const MIB: f64 = 1024.0 * 1024.0;

/// The program, its tables and thread stacks, bytes (measured: the fixed part of `tiny` and
/// `quick` less their per-cone part).
const FIXED_BYTES: f64 = 36.0 * MIB;
/// Per cone of the lattice, bytes: the eye's sampler and the cortex's per-pixel structures.
/// Measured as a run's peak less its other parts with its end reading 4 held-out scenes
/// (`/usr/bin/time -f %M colorvision train --preset P --steps 2 --set
/// schedule.held_out_scenes=4`, two runs each): 43.6 MiB on `tiny` (32² cones) and 67.2 on
/// `quick` (64²), so 7.9 KiB a cone. (Fitted before with the end's held-out samples inside:
/// 17.4.)
const PER_CONE_BYTES: f64 = 8.0 * 1024.0;
/// A reading's fixed part (`colorvision cmf-sim`: the eye with one scene tile and an observer,
/// no training) on up to [`READING_FITTED_CONES`], bytes: a constant and
/// [`READING_PER_CONE_BYTES_UP_TO_QUICK`] a cone. These are the coefficients readings' peaks
/// were checked against on the `quick` eye (375 and 461 MiB, docs/memory-tops.md); they are
/// the run's fit from before its end's held-out samples were counted apart, kept for readings,
/// which read no held-out samples but were never fitted on their own.
const READING_FIXED_BYTES: f64 = 33.0 * MIB;
/// See [`READING_FIXED_BYTES`].
const READING_PER_CONE_BYTES_UP_TO_QUICK: f64 = 17.4 * 1024.0;
/// Per cone of the lattice beyond the `quick` eye's 64² in a reading, bytes: the eye's slope,
/// measured as the peak of `colorvision simulate` less its scenes from `quick` to `large` (1.9
/// KiB a cone) and to `paper` (1.7; docs/memory-tops.md).
const READING_PER_CONE_BYTES: f64 = 1.9 * 1024.0;
/// The cones up to which a reading's per-cone part was fitted (the `quick` eye).
const READING_FITTED_CONES: f64 = 64.0 * 64.0;

/// The fixed part of a reading on `cones` cones, bytes: [`READING_PER_CONE_BYTES_UP_TO_QUICK`]
/// a cone up to [`READING_FITTED_CONES`], [`READING_PER_CONE_BYTES`] beyond.
fn reading_fixed_bytes(cones: f64) -> f64 {
    READING_FIXED_BYTES
        + READING_PER_CONE_BYTES_UP_TO_QUICK * cones.min(READING_FITTED_CONES)
        + READING_PER_CONE_BYTES * (cones - READING_FITTED_CONES).max(0.0)
}
/// The eye alone (`colorvision simulate`, `gamut`: no cortex, no observer), bytes: its fixed
/// part. Measured as the peak of `simulate` less its scenes less [`READING_PER_CONE_BYTES`] a
/// cone (docs/memory-tops.md): 35.7 MiB on `tiny`, 35.9 at 500 tiles, 34.9 on `quick`, 34.4 on
/// `large`, 26.1 on `paper` — the largest and 4 MiB for the spread between runs (`tiny`'s
/// peak read 39.5 and 40.2 MiB on two days).
const EYE_FIXED_BYTES: f64 = 40.0 * MIB;

/// The fixed part of the eye alone on `cones` cones, bytes: [`EYE_FIXED_BYTES`] and the eye's
/// [`READING_PER_CONE_BYTES`] a cone.
fn eye_fixed_bytes(cones: f64) -> f64 {
    EYE_FIXED_BYTES + READING_PER_CONE_BYTES * cones
}

/// Full scene pools a run holds at its peak: the training eye's and the held-out eye's. The
/// hidden-signal measures at its end draw their own stream beside them, of
/// [`crate::heldout::HIDDEN_POOL_TILES`] tiles ([`hidden_stream_bytes`]). Measured (one thread,
/// `/usr/bin/time -v colorvision run --preset tiny --steps 1 --set retina.scenes.tiles=1000`):
/// 702 MiB, two pools of 316 (a heap profile's, docs/memory-tops.md, when the pictures built
/// a third pool: 1 023 MiB).
const RUN_SCENE_POOLS: f64 = 2.0;
/// The page an mmap'd allocation (a tile's mip stack) is rounded up to, bytes.
const PAGE_BYTES: f64 = 4096.0;
/// Tape of a training step per sample per ONS pixel, in `f32`s: a fixed part and a part per
/// channel of the U-Net summed over its levels at their resolution (measured: the slope of
/// peak memory in `cortex.train.batch_size` on `tiny` and `quick`).
const STEP_F32_PER_PIXEL: (f64, f64) = (10.0, 17.4);
/// A decode of one show by the cortex, in `f32`s per ONS pixel of its decode window
/// ([`cmf_sim::decode_pixels`]): the slope of CMF-SIM's peak memory in `observer.decode_batch`
/// (16 shows a batch against one), measured with D's decoder on the box of cells read
/// (docs/memory-tops.md) as 131 on `quick` (whose window is the whole 64² field) and 43 per
/// pixel of the 256² field on `paper`, 110 per pixel of its 160² window; the top. (Before the
/// box: 141–194 on `quick`, 148–203 per field pixel on `paper`.)
const DECODE_F32_PER_PIXEL: f64 = 131.0;

/// One thread's decode of `decode_batch` shows by the cortex, each over `pixels` ONS pixels
/// (its decode window: [`cmf_sim::decode_pixels`]; at most the whole field), bytes
/// (`DECODE_F32_PER_PIXEL` per pixel a show). The observer keeps at most this much of the
/// whole field's idle in each thread's decoding tape between decodes.
pub fn decode_tape_bytes(decode_batch: usize, pixels: f64) -> f64 {
    decode_batch as f64 * pixels * 4.0 * DECODE_F32_PER_PIXEL
}

/// The estimated peak memory of a run and its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// The program and the per-cone structures.
    pub fixed_bytes: f64,
    /// The scene pools the command holds at once, all of them (a run: training, held-out and
    /// the hidden-signal measures' stream).
    pub scenes_bytes: f64,
    /// A training step's tape.
    pub step_bytes: f64,
    /// The observer's decodes during CMF-SIM (0 without CMF-SIM).
    pub decode_bytes: f64,
    /// P's flow parameters and their copies ([`flow`]).
    pub flow_bytes: f64,
    /// CMF-SIM's shows, readouts, location cache and solver states beside the decodes
    /// ([`cmf_sim`]; 0 without CMF-SIM).
    pub cmf_sim_bytes: f64,
    /// The hidden-signal measures' held-out samples ([`held_out_bytes`]): a run's at its end
    /// (`schedule.held_out_scenes`; 0 for a run that draws no pictures) or `convergence`'s.
    pub held_out_bytes: f64,
    /// The checkpoints held beside the measured one ([`estimate_average`]: their parameter
    /// files' sizes on disk); 0 for every command but `average`.
    pub checkpoints_bytes: f64,
}

impl Estimate {
    /// The estimated peak: the fixed part, the scenes, P's flow, the held-out samples, the
    /// checkpoints held beside the measured one, and the larger of a step and a decode (the
    /// samples are freed before CMF-SIM decodes, but the pages they took stay with the process:
    /// measured, `convergence` of a `tiny` run peaks at the sum).
    pub fn total_bytes(&self) -> f64 {
        self.fixed_bytes
            + self.scenes_bytes
            + self.flow_bytes
            + self.held_out_bytes
            + self.checkpoints_bytes
            + self.step_bytes.max(self.decode_bytes + self.cmf_sim_bytes)
    }

    /// The parts in words, each with the settings that drive it.
    pub fn parts(&self) -> String {
        let checkpoints = if self.checkpoints_bytes > 0.0 {
            format!(
                "the other checkpoints averaged {:.0} MiB (--steps), ",
                self.checkpoints_bytes / MIB
            )
        } else {
            String::new()
        };
        format!(
            "scenes {:.0} MiB (pools × retina.scenes.tiles × tile_px² × planes × mip levels), \
             training step {:.0} MiB (cortex.train.batch_size × cones_per_side² × cortex.d.widths), \
             CMF-SIM decodes {:.0} MiB (observer.decode_batch × threads × cones_per_side²), \
             CMF-SIM shows, solver and location cache {:.0} MiB (cmf_sim.location_pairs × \
             cmf_sim.n_test_wavelengths × cmf_sim.max_primaries), P's flow {:.0} MiB (cortex.p.couplings × \
             cortex.p.hidden²), held-out samples {:.0} MiB (schedule.held_out_scenes or \
             --held-out-scenes × kept cones, at most 16 × 16 a scene, × channels), {}the rest {:.0} MiB",
            self.scenes_bytes / MIB,
            self.step_bytes / MIB,
            self.decode_bytes / MIB,
            self.cmf_sim_bytes / MIB,
            self.flow_bytes / MIB,
            self.held_out_bytes / MIB,
            checkpoints,
            self.fixed_bytes / MIB
        )
    }
}

/// The cone layout of the eye of `config`.
fn layout(config: &RunConfig) -> ConeLayout {
    let r = &config.retina;
    ConeLayout::compute(&r.layout, r.cones_per_side, r.field_px, r.layout_seed)
}

/// Bytes of one scene tile of `config`'s pool: its mip stack, every level at full resolution,
/// of the planes the scenes are projected onto (the classes and the reference L, M, S,
/// [`retina::scene::projection::SceneProjection::planes_for`]), f32, in its own pages.
fn tile_bytes(config: &RunConfig, layout: &ConeLayout) -> f64 {
    let levels = ConeSampler::compute(layout).levels_needed() as f64;
    let planes = retina::MosaicSpec::parse(&config.cones)
        .and_then(|spec| {
            let classes = spec
                .class_names()
                .iter()
                .map(|n| spec.class(n))
                .collect::<Result<Vec<_>, _>>()?;
            Ok(
                retina::scene::projection::SceneProjection::planes_for(&classes)
                    .0
                    .len(),
            )
        })
        .unwrap_or(3) as f64;
    let bytes = levels * planes * (config.retina.scenes.tile_px as f64).powi(2) * 4.0;
    ((bytes + 16.0) / PAGE_BYTES).ceil() * PAGE_BYTES
}

/// The estimate for `config`; `cmf_sim` when the run measures CMF-SIM, on `threads` threads.
pub fn estimate(config: &RunConfig, cmf_sim: bool, threads: usize) -> Estimate {
    let n = config.retina.cones_per_side as f64;
    let s = &config.retina.scenes;
    let layout = layout(config);
    let channels: f64 = config
        .cortex
        .d
        .widths
        .iter()
        .enumerate()
        .map(|(level, &w)| w as f64 / 4f64.powi(level as i32))
        .sum();
    let (a, b) = STEP_F32_PER_PIXEL;
    let per_sample = n * n * 4.0 * (a + b * channels);
    // The larger of the measurements during training and the final one.
    let (decode, cmf_sim_bytes) = if cmf_sim {
        let window_px = cmf_sim::decode_pixels(config, &layout);
        let cmf_sim_bytes = [false, true]
            .map(|last| {
                let settings = config.cmf_settings(last);
                cmf_sim::bytes(config, &settings, &layout, ObserverKind::Cortex, window_px)
            })
            .into_iter()
            .fold(0.0, f64::max);
        (decodes_bytes(config, window_px, threads), cmf_sim_bytes)
    } else {
        (0.0, 0.0)
    };
    Estimate {
        fixed_bytes: FIXED_BYTES + PER_CONE_BYTES * n * n,
        scenes_bytes: (RUN_SCENE_POOLS * s.tiles as f64 + crate::heldout::HIDDEN_POOL_TILES as f64)
            * tile_bytes(config, &layout),
        held_out_bytes: held_out_bytes(config, config.schedule.held_out_scenes),
        step_bytes: config.cortex.train.batch_size as f64 * per_sample,
        decode_bytes: decode,
        flow_bytes: flow::bytes(config),
        cmf_sim_bytes,
        checkpoints_bytes: 0.0,
    }
}

/// The hidden-signal measures' own stream of held-out scenes (`crate::heldout::hidden_source`),
/// bytes: [`crate::heldout::HIDDEN_POOL_TILES`] tiles of `config`'s pool.
fn hidden_stream_bytes(config: &RunConfig) -> f64 {
    crate::heldout::HIDDEN_POOL_TILES as f64 * tile_bytes(config, &layout(config))
}

/// Bytes a held-out site keeps per value (its percept channels and class excitations, f64):
/// the samples, their concatenation and each class's fitting rows, at most 16 × 16 sites a
/// scene (`science::invariants::hidden::MAX_SITES_PER_SAMPLE`). Measured as the peak at 1 024
/// held-out scenes less the peak at a handful, per value: `colorvision convergence --run DIR
/// --held-out-scenes 1024` against `8` on a fresh `train --preset P --steps 20 --set
/// cortex.train.checkpoint_every_steps=10` folder, 41.1–46.6 bytes on `tiny` (169 sites a
/// scene, 11 values a site; four folders) and 33.7–37.0 on `quick` (225 sites; two); a run's
/// end (its hidden figures, then its own image on as many scenes again, in the pages the first
/// freed: `train --preset P --steps 2`, `schedule.held_out_scenes` 1 024 against 4) 37.5 on
/// `tiny` and 34.2–37.6 on `quick`. The largest and a little for the spread
/// (`science::budget::tests::convergence_is_estimated_at_its_measured_peaks`).
const HELD_OUT_BYTES_PER_VALUE: f64 = 47.0;

/// The hidden-signal measures' samples on `scenes` held-out scenes of `config`'s eye, bytes:
/// every kept cone inside the loss border (`science::invariants::hidden::site_stride`) with
/// its percept channels and class excitations, [`HELD_OUT_BYTES_PER_VALUE`] each.
pub fn held_out_bytes(config: &RunConfig, scenes: usize) -> f64 {
    let n = config.retina.cones_per_side;
    let side = n.saturating_sub(2 * config.cortex.loss.border_px);
    let sites = side
        .div_ceil(crate::invariants::hidden::site_stride(side))
        .pow(2);
    let classes = retina::MosaicSpec::parse(&config.cones)
        .map(|spec| spec.class_names().len())
        .unwrap_or(3);
    let scenes = scenes.div_ceil(crate::invariants::HIDDEN_BATCH_SIZE)
        * crate::invariants::HIDDEN_BATCH_SIZE;
    let values = (config.cortex.percept_dim() + classes) as f64;
    scenes as f64 * sites as f64 * values * HELD_OUT_BYTES_PER_VALUE
}

/// One scene pool of `config`, bytes.
fn pool_bytes(config: &RunConfig) -> f64 {
    config.retina.scenes.tiles as f64 * tile_bytes(config, &layout(config))
}

/// `estimate` (of `config`) for a run that draws no pictures: its training and held-out pools
/// only (the hidden-signal measures' stream is drawn for the pictures).
pub fn without_pictures(config: &RunConfig, estimate: Estimate) -> Estimate {
    Estimate {
        scenes_bytes: estimate.scenes_bytes - hidden_stream_bytes(config),
        held_out_bytes: 0.0,
        ..estimate
    }
}

/// The estimate for a command that builds the eye alone (`simulate`, `gamut`): the eye's fixed
/// part (`eye_fixed_bytes`) and one scene pool (no held-out pool, no cortex, no CMF-SIM).
pub fn estimate_eye(config: &RunConfig) -> Estimate {
    let e = estimate(config, false, 1);
    Estimate {
        fixed_bytes: eye_fixed_bytes((config.retina.cones_per_side as f64).powi(2)),
        scenes_bytes: pool_bytes(config),
        step_bytes: 0.0,
        flow_bytes: 0.0,
        held_out_bytes: 0.0,
        ..e
    }
}

/// The estimate for `colorvision cmf-sim` of observer `kind` through the eye of `config` (its
/// `cmf_sim` settings), on `threads` threads: no training step; the cortex's decodes only for
/// the cortex; the search's buffers sized by that observer's readout.
pub fn estimate_cmf_sim(config: &RunConfig, kind: ObserverKind, threads: usize) -> Estimate {
    let mut e = estimate(config, false, threads);
    let layout = layout(config);
    e.fixed_bytes = reading_fixed_bytes((config.retina.cones_per_side as f64).powi(2));
    e.step_bytes = 0.0;
    e.held_out_bytes = 0.0;
    let window_px = if kind == ObserverKind::Cortex {
        let window_px = cmf_sim::decode_pixels(config, &layout);
        e.decode_bytes = decodes_bytes(config, window_px, threads);
        window_px
    } else {
        e.flow_bytes = 0.0;
        (config.retina.cones_per_side as f64).powi(2)
    };
    e.cmf_sim_bytes = cmf_sim::bytes(config, &config.cmf_sim, &layout, kind, window_px);
    e
}

/// The cortex's decodes on `threads` threads, each of `observer.decode_batch` shows on
/// `window_px` ONS pixels ([`decode_tape_bytes`]).
fn decodes_bytes(config: &RunConfig, window_px: f64, threads: usize) -> f64 {
    threads as f64 * decode_tape_bytes(config.observer.decode_batch, window_px)
}

/// The estimate for `colorvision convergence` of a run of `config` (with CMF-SIM at its
/// checkpoints when `cmf_sim`), on `threads` threads, its hidden-signal measures on
/// `held_out_scenes` scenes: the eye's fixed part ([`eye_fixed_bytes`]: the checkpoint's cortex
/// without a training step's structures fits in what its top leaves; measured at 8 held-out
/// scenes with the scene pool, 39.3 MiB on `tiny` and 69.2 on `quick`, estimated 45 and 89),
/// P's flow and its copies, one scene pool (the held-out eye), the held-out samples, CMF-SIM's
/// decodes and its own part when it measures; no training step is taken.
pub fn estimate_convergence(
    config: &RunConfig,
    cmf_sim: bool,
    threads: usize,
    held_out_scenes: usize,
) -> Estimate {
    let e = estimate(config, false, threads);
    let layout = layout(config);
    let (decode_bytes, cmf_sim_bytes) = if cmf_sim {
        let window_px = cmf_sim::decode_pixels(config, &layout);
        (
            decodes_bytes(config, window_px, threads),
            cmf_sim::bytes(
                config,
                &config.cmf_sim,
                &layout,
                ObserverKind::Cortex,
                window_px,
            ),
        )
    } else {
        (0.0, 0.0)
    };
    Estimate {
        fixed_bytes: eye_fixed_bytes((config.retina.cones_per_side as f64).powi(2)),
        scenes_bytes: pool_bytes(config),
        step_bytes: 0.0,
        decode_bytes,
        cmf_sim_bytes,
        held_out_bytes: held_out_bytes(config, held_out_scenes),
        ..e
    }
}

/// The estimate for `colorvision average` of a run of `config` on `threads` threads: what
/// `convergence` of one checkpoint holds with CMF-SIM (the run's `cmf_sim` settings, its hidden
/// measures on `schedule.held_out_scenes`) and the other checkpoints averaged into it, each as
/// large in memory as its parameter file (`other_checkpoints_bytes`, their sizes on disk, f32 as
/// stored; a loaded checkpoint starts a fresh optimiser). They are freed once averaged, but the
/// pages they took may stay with the process, so they are counted beside the rest.
pub fn estimate_average(
    config: &RunConfig,
    threads: usize,
    other_checkpoints_bytes: f64,
) -> Estimate {
    Estimate {
        checkpoints_bytes: other_checkpoints_bytes,
        ..estimate_convergence(config, true, threads, config.schedule.held_out_scenes)
    }
}

/// Fraction of the memory there is that a run may plan to take.
pub const LIMIT_FRACTION: f64 = 0.8;

/// The memory there is, bytes, and where the figure comes from: the cgroup's limit where there
/// is one (v2 `memory.max`, v1 `memory.limit_in_bytes`), else the machine's available memory
/// (`MemAvailable` of `/proc/meminfo`); `None` where neither can be read.
pub fn memory_available() -> Option<(f64, &'static str)> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    for path in [
        "/sys/fs/cgroup/memory.max",
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ] {
        if let Some(v) = read(path).and_then(|t| t.trim().parse::<f64>().ok()) {
            // v1 reports "no limit" as a huge number.
            if v < 1e15 {
                return Some((v, "the cgroup's memory limit"));
            }
        }
    }
    let meminfo = read("/proc/meminfo")?;
    let kib = meminfo
        .lines()
        .find_map(|l| l.strip_prefix("MemAvailable:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse::<f64>()
        .ok()?;
    Some((kib * 1024.0, "the available memory"))
}

/// Refuses a run whose estimate exceeds `limit_bytes` (and names what drives it); `source`
/// says where the limit comes from.
pub fn check(estimate: &Estimate, limit_bytes: f64, source: &str) -> Result<(), crate::Error> {
    let total = estimate.total_bytes();
    if total <= limit_bytes {
        return Ok(());
    }
    Err(crate::Error::invalid(
        "memory",
        format!(
            "the run would take about {:.0} MiB, over the limit of {:.0} MiB ({source}): {}. \
             Lower the settings that drive the largest part",
            total / MIB,
            limit_bytes / MIB,
            estimate.parts()
        ),
    ))
}

#[cfg(test)]
mod tests;
