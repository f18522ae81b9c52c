//! How much memory a run takes, estimated from its settings before anything is allocated, and
//! the limit it must stay under.
//!
//! Conventions: sizes in bytes (`_bytes`), said in MiB. The estimate is the peak resident
//! memory of the process: a fixed part (the program, its tables, the eye and the cortex per
//! cone), the two scene pools (training and held-out: every tile's mip stack of class planes),
//! and the larger of a training step (the autodiff tape of a batch) and, when CMF-SIM runs, a
//! decode of the observer (each thread's tape over `observer.decode_batch` shows); the two never
//! overlap. The coefficients are peak resident memory measured on the `tiny` and `quick` presets
//! (2 threads; `tests/memory_budget.rs` checks the estimate within ±30 % of the measured peak).
//! Two parts that grow without bound at the tops of their ranges are modelled from their shapes
//! instead: P's flow parameters and their copies ([`flow`], `cortex.p.hidden`), and CMF-SIM's
//! shows, readouts, per-location cache and solver states ([`cmf_sim`], `cmf_sim.location_pairs`
//! × `cmf_sim.n_test_wavelengths` × `cmf_sim.max_primaries`), which CMF-SIM holds beside its
//! decodes.
//!
//! Three estimates: [`estimate`] for a run (training, and CMF-SIM of its cortex when it
//! measures), [`estimate_cmf_sim`] for `colorvision cmf-sim` of any observer (no training step;
//! the search's buffers sized by that observer's readout, the cortex's decodes only for the
//! cortex), and [`estimate_eye`] for the commands that build the eye alone (`simulate`,
//! `gamut`: one scene pool).

use crate::config::RunConfig;
use crate::observer::ObserverKind;
use retina::foveation::{ConeLayout, ConeSampler};

pub mod cmf_sim;
pub mod flow;

const MIB: f64 = 1024.0 * 1024.0;

/// The program, its tables and thread stacks, bytes (measured: the fixed part of `tiny` and
/// `quick` less their per-cone part).
const FIXED_BYTES: f64 = 33.0 * MIB;
/// Per cone of the lattice, bytes: the eye's sampler and the cortex's per-pixel structures
/// (measured: `quick` and `tiny` differ by 52 MiB over 3 072 cones).
const PER_CONE_BYTES: f64 = 17.4 * 1024.0;
/// Full-size planes per cone class a tile takes beyond its mip levels (the planes it is drawn
/// from, and their copies while drawn; measured: 1.9 MiB per `quick` tile of 192² px, 3 classes
/// and 3 levels, is 4.6 planes per class).
const TILE_PLANES_PER_CLASS: f64 = 1.6;
/// Tape of a training step per sample per ONS pixel, in `f32`s: a fixed part and a part per
/// channel of the U-Net summed over its levels at their resolution (measured: the slope of
/// peak memory in `cortex.train.batch_size` on `tiny` and `quick`).
const STEP_F32_PER_PIXEL: (f64, f64) = (10.0, 17.4);
/// A decode of one show by the cortex, in `f32`s per ONS pixel (cones_per_side²): the slope of
/// CMF-SIM's peak memory in `observer.decode_batch` (a 12-show batch against one show), measured
/// as 171 on `tiny` (32²), 141–194 on `quick` (64²) and 148–203 on `paper` (256², D on its
/// windows), the last two between 11 and 15 extra shows a batch (docs/memory-tops.md); the top.
const DECODE_F32_PER_PIXEL: f64 = 205.0;

/// One thread's decode of `decode_batch` shows by the cortex of an eye of `cones_per_side²`
/// cones, bytes ([`DECODE_F32_PER_PIXEL`] per ONS pixel a show). The observer keeps at most
/// this much idle in each thread's decoding tape between decodes.
pub fn decode_tape_bytes(decode_batch: usize, cones_per_side: usize) -> f64 {
    decode_batch as f64 * (cones_per_side as f64).powi(2) * 4.0 * DECODE_F32_PER_PIXEL
}

/// The estimated peak memory of a run and its parts.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// The program and the per-cone structures.
    pub fixed_bytes: f64,
    /// The training and held-out scene pools.
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
}

impl Estimate {
    /// The estimated peak: the fixed part, the scenes and the larger of a step and a decode.
    pub fn total_bytes(&self) -> f64 {
        self.fixed_bytes
            + self.scenes_bytes
            + self.flow_bytes
            + self.step_bytes.max(self.decode_bytes + self.cmf_sim_bytes)
    }

    /// The parts in words, each with the settings that drive it.
    pub fn parts(&self) -> String {
        format!(
            "scenes {:.0} MiB (retina.scenes.tiles × tile_px² × cone classes, twice), training \
             step {:.0} MiB (cortex.train.batch_size × cones_per_side² × cortex.d.widths), \
             CMF-SIM decodes {:.0} MiB (observer.decode_batch × threads × cones_per_side²), \
             CMF-SIM shows, solver and location cache {:.0} MiB (cmf_sim.location_pairs × \
             cmf_sim.n_test_wavelengths × cmf_sim.max_primaries), P's flow {:.0} MiB (cortex.p.couplings × \
             cortex.p.hidden²), the rest {:.0} MiB",
            self.scenes_bytes / MIB,
            self.step_bytes / MIB,
            self.decode_bytes / MIB,
            self.cmf_sim_bytes / MIB,
            self.flow_bytes / MIB,
            self.fixed_bytes / MIB
        )
    }
}

/// The cone layout of the eye of `config`.
fn layout(config: &RunConfig) -> ConeLayout {
    let r = &config.retina;
    ConeLayout::compute(&r.layout, r.cones_per_side, r.field_px, r.layout_seed)
}

/// The estimate for `config`; `cmf_sim` when the run measures CMF-SIM, on `threads` threads.
pub fn estimate(config: &RunConfig, cmf_sim: bool, threads: usize) -> Estimate {
    let n = config.retina.cones_per_side as f64;
    let classes = retina::MosaicSpec::parse(&config.cones)
        .map(|s| s.class_names().len())
        .unwrap_or(3) as f64;
    let s = &config.retina.scenes;
    let layout = layout(config);
    let mip_levels = ConeSampler::compute(&layout).levels_needed();
    let tile_bytes =
        (mip_levels as f64 + TILE_PLANES_PER_CLASS) * classes * (s.tile_px as f64).powi(2) * 4.0;
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
    let decode = if cmf_sim {
        threads as f64
            * decode_tape_bytes(config.observer.decode_batch, config.retina.cones_per_side)
    } else {
        0.0
    };
    // The larger of the measurements during training and the final one.
    let cmf_sim_bytes = if cmf_sim {
        [false, true]
            .map(|last| {
                let settings = config.cmf_settings(last);
                cmf_sim::bytes(config, &settings, &layout, ObserverKind::Cortex)
            })
            .into_iter()
            .fold(0.0, f64::max)
    } else {
        0.0
    };
    Estimate {
        fixed_bytes: FIXED_BYTES + PER_CONE_BYTES * n * n,
        scenes_bytes: 2.0 * s.tiles as f64 * tile_bytes,
        step_bytes: config.cortex.train.batch_size as f64 * per_sample,
        decode_bytes: decode,
        flow_bytes: flow::bytes(config),
        cmf_sim_bytes,
    }
}

/// The estimate for a command that builds the eye alone (`simulate`, `gamut`): the fixed part
/// and one scene pool (no held-out pool, no cortex, no CMF-SIM).
pub fn estimate_eye(config: &RunConfig) -> Estimate {
    let e = estimate(config, false, 1);
    Estimate {
        scenes_bytes: e.scenes_bytes / 2.0,
        step_bytes: 0.0,
        flow_bytes: 0.0,
        ..e
    }
}

/// The estimate for `colorvision cmf-sim` of observer `kind` through the eye of `config` (its
/// `cmf_sim` settings), on `threads` threads: no training step; the cortex's decodes only for
/// the cortex; the search's buffers sized by that observer's readout.
pub fn estimate_cmf_sim(config: &RunConfig, kind: ObserverKind, threads: usize) -> Estimate {
    let mut e = estimate(config, true, threads);
    e.step_bytes = 0.0;
    if kind != ObserverKind::Cortex {
        e.decode_bytes = 0.0;
        e.flow_bytes = 0.0;
    }
    e.cmf_sim_bytes = cmf_sim::bytes(config, &config.cmf_sim, &layout(config), kind);
    e
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
mod tests {
    use super::*;

    #[test]
    fn every_part_grows_with_the_settings_that_drive_it() {
        let base = RunConfig::preset("quick", "LMS").unwrap();
        let e = estimate(&base, true, 2);
        let mut c = base.clone();
        c.retina.scenes.tiles *= 2;
        assert!((estimate(&c, true, 2).scenes_bytes - 2.0 * e.scenes_bytes).abs() < 1.0);
        let mut c = base.clone();
        c.cortex.train.batch_size *= 2;
        assert!((estimate(&c, true, 2).step_bytes - 2.0 * e.step_bytes).abs() < 1.0);
        assert_eq!(estimate(&base, false, 2).decode_bytes, 0.0);
        assert!(estimate(&base, true, 4).decode_bytes > e.decode_bytes);
    }

    #[test]
    fn the_flow_part_counts_the_parameters_realnvp_makes() {
        let mut c = RunConfig::preset("tiny", "LMS").unwrap();
        for hidden in [16, 64] {
            c.cortex.p.hidden = hidden;
            let mut store = autodiff::ParamStore::<f32>::new();
            let flow = autodiff::nn::realnvp::RealNvp::new(
                &mut store,
                "p",
                autodiff::nn::realnvp::RealNvpConfig {
                    blocks: c.cortex.p.couplings,
                    hidden,
                    log_scale_bound: None,
                },
                &mut <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(0),
            );
            let params_bytes = 4.0 * flow.num_params() as f64;
            let per_coupling = params_bytes / c.cortex.p.couplings as f64;
            let points = (c.cortex.train.batch_size * c.cortex.ons_size_px.pow(2)) as f64;
            let partials = (points / autodiff::nn::coupling::BLOCK as f64).ceil() * per_coupling;
            assert!((flow::bytes(&c) - (10.0 * params_bytes + partials)).abs() < 1.0);
        }
    }

    #[test]
    fn the_cmf_sim_part_grows_with_the_pairs_and_holds_the_measured_top() {
        let c = RunConfig::preset("tiny", "LMS").unwrap();
        let layout = layout(&c);
        let at = |pairs: usize| {
            let mut s = c.cmf_settings(true);
            s.location_pairs = pairs;
            cmf_sim::bytes(&c, &s, &layout, ObserverKind::Cortex)
        };
        // More pairs, more shows and cached locations.
        assert!(at(8) > at(4), "{} {}", at(4), at(8));
        // At the top of its range the estimate must not fall below what was measured there: a
        // tiny run with 4 096 location pairs had reached 2 375 MiB when it was stopped
        // unfinished (docs/memory-tops.md), a lower bound on its peak.
        let top = at(4096);
        assert!(top >= 2375.0 * 1024.0 * 1024.0, "{top} bytes");
    }

    #[test]
    fn the_cmf_sim_part_counts_the_solvers_states_per_primary() {
        let c = RunConfig::preset("quick", "LMSQ,Q:506").unwrap();
        let layout = layout(&c);
        let s = c.cmf_settings(true);
        let rows = (s.n_test_wavelengths * s.location_pairs) as f64
            * cmf_sim::readout_len(&c, &layout, ObserverKind::Cortex) as f64;
        let at = |k: usize| {
            let mut s = s.clone();
            s.max_primaries = k;
            cmf_sim::bytes(&c, &s, &layout, ObserverKind::Cortex)
        };
        // Each primary more: two Jacobian columns in every state and two readouts a row in the
        // Jacobian pass, f64.
        assert!(at(4) - at(3) >= 4.0 * rows * 8.0, "{} {}", at(3), at(4));
        let mut off = s.clone();
        off.front_end_jacobians = false;
        assert!(cmf_sim::bytes(&c, &off, &layout, ObserverKind::Cortex) < at(s.max_primaries));
    }

    #[test]
    fn a_quick_tetrachromat_reading_is_estimated_at_its_measured_peak() {
        // Measured (docs/memory-tops.md): one thread, `cmf-sim --run` on a 2 000-step
        // `--preset main --cones LMSQ,Q:506` checkpoint, location seed 0: peak 461 MiB.
        let c = RunConfig::preset("main", "LMSQ,Q:506").unwrap();
        let m = crate::measure::measurement_config(&c);
        let e = estimate_cmf_sim(&m, ObserverKind::Cortex, 1).total_bytes() / MIB;
        assert!((461.0..=1.3 * 461.0).contains(&e), "{e:.0} MiB");
    }

    #[test]
    fn an_observer_without_a_cortex_is_estimated_by_its_own_readout() {
        // The analytic observer at the top of location_pairs: one value per class a show, no
        // decodes, no location cache. Measured (docs/memory-tops.md, `scripts/memory-tops.sh`):
        // `cmf-sim --observer analytic --preset tiny --set cmf_sim.location_pairs=4096` peaked
        // at 227 MiB resident. With the cortex's readout the estimate was 20 007 MiB, refusing
        // the run. It must not fall below the peak; it is 1.7 × above it (the aim, 1.3 ×, is
        // not met yet: docs/memory-tops.md), and twice the peak bounds it against regressions.
        let mut c = RunConfig::preset("tiny", "LMS").unwrap();
        c.cmf_sim.location_pairs = 4096;
        let m = crate::measure::measurement_config(&c);
        let analytic = estimate_cmf_sim(&m, ObserverKind::Analytic, 1);
        let cortex = estimate_cmf_sim(&m, ObserverKind::Cortex, 1);
        assert_eq!(analytic.decode_bytes, 0.0);
        assert!(analytic.cmf_sim_bytes < cortex.cmf_sim_bytes / 10.0);
        let e = analytic.total_bytes() / MIB;
        assert!((227.0..=2.0 * 227.0).contains(&e), "{e:.0} MiB");
    }

    #[test]
    fn a_run_over_the_limit_is_refused_naming_what_drives_it() {
        let mut c = RunConfig::preset("tiny", "LMS").unwrap();
        c.retina.scenes.tiles = 1_000_000;
        let e = estimate(&c, true, 2);
        let msg = check(&e, 8.0 * 1024.0 * MIB, "a test")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("retina.scenes.tiles") && msg.contains("MiB"),
            "{msg}"
        );
        assert!(!msg.contains('\n'));
        assert!(check(
            &estimate(&RunConfig::preset("tiny", "LMS").unwrap(), true, 2),
            8.0 * 1024.0 * MIB,
            "a test"
        )
        .is_ok());
    }

    #[test]
    fn the_memory_there_is_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let (bytes, _) = memory_available().expect("readable on Linux");
            assert!(bytes > 1e6, "{bytes}");
        }
    }
}
