//! The valid range of every numeric setting of a [`RunConfig`], checked before anything is
//! made: a value outside its range (NaN included) is an error naming the field, its range and
//! its unit.
//!
//! Conventions: a key is a setting's dotted name as in a `--config` file; `[]` stands for every
//! element of an array and `*` for any one table key. Bounds are inclusive unless
//! `min_excluded`. The ranges bound what is meaningful or what a stage can compute in finite
//! time and finite numbers; how much memory the settings take together is checked apart
//! (the run's budget). The settings of a learning rule (`[rule]`) are checked by the rule's own
//! registry entry (`cortex::rule::check`) and are not listed here. A test walks every numeric
//! field of every preset and fails if one has no range here.

use super::{ConfigError, RunConfig};

/// The valid range of one numeric setting.
#[derive(Clone, Copy, Debug)]
pub struct Range {
    /// The setting's dotted name (module docs).
    pub key: &'static str,
    /// Smallest valid value.
    pub min: f64,
    /// Largest valid value.
    pub max: f64,
    /// The smallest value itself is invalid (a positive quantity: `min` is 0).
    pub min_excluded: bool,
    /// Unit and meaning, said in the error.
    pub what: &'static str,
}

const fn r(key: &'static str, min: f64, max: f64, what: &'static str) -> Range {
    Range {
        key,
        min,
        max,
        min_excluded: false,
        what,
    }
}

/// A positive quantity at most `max`.
const fn pos(key: &'static str, max: f64, what: &'static str) -> Range {
    Range {
        key,
        min: 0.0,
        max,
        min_excluded: true,
        what,
    }
}

/// Largest seed: config.toml's integers are signed 64-bit.
const SEED_MAX: f64 = i64::MAX as f64;
/// Largest step count or step interval accepted (10⁹ steps is years on any machine).
const STEPS_MAX: f64 = 1e9;
/// The wavelengths any stage tabulates, nm: the CIE tables' 360–830 nm with margin.
const NM_MIN: f64 = 300.0;
/// See [`NM_MIN`].
const NM_MAX: f64 = 900.0;

/// Every numeric setting's range (module docs).
#[rustfmt::skip]
pub const RANGES: &[Range] = &[
    r("seed", 0.0, SEED_MAX, "a seed (TOML integers are signed 64-bit)"),
    r("steps", 1.0, STEPS_MAX, "gradient updates"),
    r("retina.cones_per_side", 2.0, 2048.0, "cones per side of the lattice"),
    r("retina.field_px", 2.0, 8192.0, "scene field side, px"),
    r("retina.mosaic_seed", 0.0, SEED_MAX, "a seed"),
    r("retina.layout_seed", 0.0, SEED_MAX, "a seed"),
    r("retina.scene_seed", 0.0, SEED_MAX, "a seed"),
    pos("retina.layout.Foveated.edge_eccentricity_deg", 60.0, "eccentricity of the field's edge, deg"),
    r("retina.layout.Foveated.density.peak_density_per_deg2", 1.0, 1e6, "foveal cone density, cones/deg² (human ≈ 14 800, Watson 2014 from the data of Curcio et al. 1990)"),
    pos("retina.layout.Foveated.density.scale_eccentricity_deg", 90.0, "eccentricity scale of the density fall-off, deg"),
    r("retina.layout.Foveated.jitter.octaves", 1.0, 16.0, "octaves of the jitter noise"),
    r("retina.layout.Foveated.jitter.persistence", 0.0, 4.0, "amplitude ratio of successive jitter octaves"),
    r("retina.layout.Foveated.jitter.base_resolution", 1.0, 4096.0, "cells of the coarsest jitter octave"),
    r("retina.layout.Foveated.jitter.amplitude_cells", 0.0, 4.0, "jitter amplitude, cone spacings (beyond a few the lattice folds over itself)"),
    r("retina.grid.start_nm", NM_MIN, NM_MAX, "first wavelength of the grid, nm"),
    r("retina.grid.end_nm", NM_MIN, NM_MAX, "last wavelength of the grid, nm"),
    r("retina.grid.step_nm", 1.0, 50.0, "wavelength grid spacing, nm (the CIE tables are at 1 nm at finest)"),
    pos("retina.template.optical_density", 3.0, "peak photopigment optical density"),
    r("retina.eye_motion.max_shift_px", 1.0, 1024.0, "largest eye shift, px"),
    r("retina.noise.photon_noise_scale", 0.0, 10.0, "photon noise σ per unit √signal"),
    r("retina.noise.li_noise_scale", 0.0, 10.0, "relative noise of the lateral-inhibition output"),
    r("retina.noise.noise_levels", 1.0, 1e6, "levels of the drawn noise ratio"),
    pos("retina.lateral_inhibition.sigma_centre_cells", 400.0, "centre σ, cone spacings"),
    pos("retina.lateral_inhibition.sigma_surround_cells", 400.0, "surround σ, cone spacings"),
    r("retina.lateral_inhibition.surround_weight", 0.0, 10.0, "surround weight relative to the centre"),
    r("retina.lif.decay", 0.0, 1.0, "membrane decay per time step"),
    pos("retina.lif.threshold", 1e3, "spike threshold"),
    r("retina.lif.drive_gain", 0.0, 1e3, "drive gain"),
    r("retina.scenes.tiles", 1.0, 1e6, "scene tiles held"),
    r("retina.scenes.tile_px", 2.0, 65536.0, "scene tile side, px"),
    r("retina.scenes.refresh_every_batches", 0.0, STEPS_MAX, "batches between tile refreshes (0: never)"),
    r("retina.scenes.tetra.fraction", 0.0, 1.0, "fraction of tiles"),
    r("retina.scenes.dead_leaves.size_px", 2.0, 65536.0, "dead-leaves scene side, px"),
    pos("retina.scenes.dead_leaves.radius_min_px", 1e4, "smallest leaf radius, px"),
    pos("retina.scenes.dead_leaves.radius_max_fraction", 1.0, "largest leaf radius, fraction of the scene side"),
    r("retina.scenes.dead_leaves.size_exponent", 0.0, 10.0, "exponent of the leaf-size density (3: scale invariant, Lee et al. 2001)"),
    r("retina.scenes.dead_leaves.max_aspect", 1.0, 100.0, "largest leaf aspect ratio"),
    r("retina.scenes.dead_leaves.rectangle_fraction", 0.0, 1.0, "fraction of rectangular leaves"),
    r("retina.scenes.dead_leaves.leaf_brightness_range[]", 0.0, 10.0, "leaf brightness factor"),
    r("retina.scenes.dead_leaves.leaf_shading_gradient", 0.0, 10.0, "shading slope per leaf radius"),
    r("retina.scenes.dead_leaves.sun_cct_k[]", 1000.0, 100_000.0, "correlated colour temperature, K"),
    r("retina.scenes.dead_leaves.sky_cct_k[]", 1000.0, 100_000.0, "correlated colour temperature, K"),
    r("retina.scenes.dead_leaves.sky_relative_luminance", 0.0, 100.0, "sky luminance relative to the sun"),
    r("retina.scenes.dead_leaves.illumination_log_amplitude", 0.0, 10.0, "log illumination amplitude, natural-log units"),
    r("retina.scenes.dead_leaves.shadow_edge_gain", 0.0, 1e3, "logistic gain of shadow edges"),
    r("retina.scenes.dead_leaves.max_leaves", 1.0, 1e8, "leaves per scene"),
    r("retina.scenes.surfaces.radius_max_px", 0.0, 65536.0, "largest surface radius, px"),
    r("retina.scenes.surfaces.texture_log_sigma", 0.0, 10.0, "texture σ, natural-log units"),
    pos("retina.scenes.surfaces.texture_period_px", 65536.0, "texture period, px"),
    r("retina.scenes.surfaces.texture_octaves", 1.0, 16.0, "texture octaves"),
    r("retina.scenes.surfaces.texture_persistence", 0.0, 4.0, "amplitude ratio of successive octaves"),
    r("retina.scenes.surfaces.pigment_mix_max", 0.0, 1.0, "weight of the second pigment"),
    pos("retina.scenes.surfaces.pigment_period_px", 65536.0, "pigment-field period, px"),
    r("retina.scenes.surfaces.pigment_octaves", 1.0, 16.0, "pigment-field octaves"),
    r("retina.scenes.surfaces.pigment_persistence", 0.0, 4.0, "amplitude ratio of successive octaves"),
    r("retina.scenes.surfaces.texture_fields", 1.0, 1024.0, "texture fields per scene"),
    r("retina.scenes.band_stack.first_nm", NM_MIN, NM_MAX, "wavelength of the first band, nm"),
    pos("retina.scenes.band_stack.step_nm", 100.0, "step between bands, nm"),
    r("cortex.ons_size_px", 8.0, 2048.0, "ONS side, px"),
    r("cortex.percept_channels", 1.0, 1024.0, "percept channels"),
    pos("cortex.w.inverse_guard", 1.0, "guard of W's inverse"),
    r("cortex.c.norm_eps", 0.0, 1.0, "ε of C's normalisation"),
    r("cortex.d.widths[]", 1.0, 4096.0, "U-Net level width, channels"),
    r("cortex.p.couplings", 1.0, 64.0, "coupling blocks of the flow"),
    r("cortex.p.hidden", 1.0, 4096.0, "hidden width of a coupling"),
    pos("cortex.p.log_scale_bound", 20.0, "bound on a coupling's log-scale"),
    pos("cortex.p.motion_ons_px_per_unit", 1e4, "ONS px per unit of motion"),
    r("cortex.m.blur_kernel_px", 1.0, 255.0, "blur kernel side, px"),
    pos("cortex.m.blur_sigma_px", 100.0, "blur σ, px"),
    r("cortex.m.search_radius_px", 0.0, 64.0, "block-matching search radius, px"),
    r("cortex.m.coarsest_level_px", 2.0, 2048.0, "coarsest pyramid level side, px"),
    pos("cortex.m.min_overlap_fraction", 1.0, "fraction of overlapping pixels"),
    r("cortex.m.refine_iterations", 0.0, 100.0, "refinement iterations"),
    pos("cortex.m.refine_fd_step_px", 10.0, "finite-difference step, px"),
    r("cortex.m.refine_stride_px", 1.0, 64.0, "refinement stride, px"),
    pos("cortex.m.refine_max_step_px", 100.0, "largest refinement step, px"),
    r("cortex.m.blur_loss_weight", 0.0, 1e3, "loss weight"),
    r("cortex.m.gauge_weight", 0.0, 1e3, "loss weight"),
    r("cortex.loss.border_px", 0.0, 1024.0, "border left out of the loss, px"),
    r("cortex.loss.outside_field_weight", 0.0, 1e3, "loss weight"),
    r("cortex.train.batch_size", 1.0, 4096.0, "scenes per batch"),
    pos("cortex.train.learning_rate", 10.0, "learning rate"),
    r("cortex.train.sgd_momentum", 0.0, 0.999, "SGD momentum (below 1)"),
    r("cortex.train.adam_beta1", 0.0, 0.999_999, "Adam β₁ (below 1)"),
    r("cortex.train.adam_beta2", 0.0, 0.999_999_999, "Adam β₂ (below 1)"),
    pos("cortex.train.adam_eps", 1.0, "Adam ε"),
    r("cortex.train.seed", 0.0, SEED_MAX, "a seed"),
    r("cortex.train.steps", 1.0, STEPS_MAX, "gradient updates"),
    r("cortex.train.checkpoint_every_steps", 0.0, STEPS_MAX, "steps (0: the last only)"),
    r("cortex.train.w_learning_rate_scale", 0.0, 1e3, "factor of the learning rate"),
    pos("cortex.train.final_lr_fraction", 1.0, "fraction of the learning rate"),
    pos("cortex.train.clip_global_norm", 1e12, "largest update norm"),
    r("cortex.train.alignment_every_steps", 0.0, STEPS_MAX, "steps (0: never)"),
    r("cortex.train.per_bucket.*.learning_rate_scale", 0.0, 1e3, "factor of the learning rate"),
    pos("cortex.train.per_bucket.*.clip_norm", 1e12, "largest update norm"),
    r("cmf_sim.n_test_wavelengths", 2.0, 10_000.0, "test wavelengths"),
    r("cmf_sim.test_range_nm[]", NM_MIN, NM_MAX, "wavelength, nm"),
    r("cmf_sim.primary_range_nm[]", NM_MIN, NM_MAX, "wavelength, nm"),
    r("cmf_sim.max_primaries", 1.0, 8.0, "primaries (CMF-SIM tries at most 8)"),
    r("cmf_sim.margins_through_k", 0.0, 8.0, "primaries (CMF-SIM tries at most 8)"),
    r("cmf_sim.sets_per_k", 1.0, 1e6, "primary sets per K"),
    r("cmf_sim.location_pairs", 1.0, 4096.0, "location pairs"),
    r("cmf_sim.pass_ratio", 1.0, 1e3, "error ratio to the base error (paper: 1.5)"),
    r("cmf_sim.base_error_floor_rel", 0.0, 1.0, "fraction of the largest percept energy"),
    r("cmf_sim.first_round_wavelengths", 1.0, 10_000.0, "wavelengths"),
    r("cmf_sim.converged_sets", 1.0, 1e6, "primary sets"),
    r("cmf_sim.min_primary_separation_nm", 0.0, 600.0, "spacing of two primaries, nm"),
    pos("cmf_sim.intensity", 1e6, "test-light intensity"),
    r("cmf_sim.seed", 0.0, SEED_MAX, "a seed"),
    r("cmf_sim.solver.max_iterations", 1.0, 1000.0, "solver iterations"),
    pos("cmf_sim.solver.fd_step", 1.0, "finite-difference step"),
    r("cmf_sim.solver.rel_tolerance", 0.0, 1.0, "relative tolerance"),
    r("cmf_sim.solver.exact_match_rel", 0.0, 1.0, "relative error"),
    pos("observer.patch_radius_fraction", 0.5, "fraction of the field side"),
    r("observer.fringe_cones", 0.0, 100.0, "cone spacings"),
    pos("observer.peak_response", 100.0, "single-class response"),
    r("observer.noise_ratio", 0.0, 10.0, "noise ratio"),
    r("observer.decode_batch", 1.0, 4096.0, "shows per cortex call"),
    pos("observer.sample_spacing_cones", 100.0, "cone spacings"),
    r("observer.edge_clearance_cones", 0.0, 1e3, "cone spacings"),
    r("schedule.cmf_every_steps", 0.0, STEPS_MAX, "steps (0: the end only)"),
    r("schedule.cmf_extra_steps[]", 0.0, STEPS_MAX, "a step"),
    r("schedule.pictures_every_steps", 0.0, STEPS_MAX, "steps (0: the end only)"),
    r("schedule.eval_every_steps", 0.0, STEPS_MAX, "steps"),
    r("schedule.eval_batches", 1.0, 10_000.0, "held-out batches per measurement"),
    r("schedule.held_out_scenes", 2.0, 4096.0, "held-out scenes of the hidden-signal figures"),
    r("schedule.stop_at_dimension", 0.0, 64.0, "a dimension (0: never stop early)"),
    r("schedule.checkpoint_cmf_sets_per_k", 0.0, 1e6, "primary sets per K (0: as cmf_sim)"),
    r("schedule.checkpoint_cmf_wavelengths", 0.0, 10_000.0, "test wavelengths (0: as cmf_sim)"),
    r("schedule.checkpoint_cmf_location_pairs", 0.0, 4096.0, "location pairs (0: as cmf_sim)"),
];

/// Tables whose settings have the ranges of another's: the leaves of `surfaces` scenes are
/// dead leaves.
const SAME_AS: &[(&str, &str)] = &[("retina.scenes.surfaces.leaves", "retina.scenes.dead_leaves")];

/// The range of the numeric setting at `path` (its dotted key parts, `[]` for an element).
pub fn range_of(path: &[&str]) -> Option<&'static Range> {
    let joined = path.join(".");
    for (alias, table) in SAME_AS {
        if let Some(rest) = joined.strip_prefix(&format!("{alias}.")) {
            let key = format!("{table}.{rest}");
            return range_of(&key.split('.').collect::<Vec<_>>());
        }
    }
    RANGES.iter().find(|r| {
        let parts: Vec<&str> = r.key.split('.').collect();
        parts.len() == path.len() && parts.iter().zip(path).all(|(p, q)| *p == "*" || p == q)
    })
}

/// Every numeric value of `value` with its path (dotted parts; an array element's part is its
/// array's name with `[]` appended), in order. `[rule]` is left out (module docs).
pub fn numeric_fields(value: &toml::Value) -> Vec<(Vec<String>, f64)> {
    fn walk(v: &toml::Value, path: &mut Vec<String>, out: &mut Vec<(Vec<String>, f64)>) {
        match v {
            toml::Value::Integer(i) => out.push((path.clone(), *i as f64)),
            toml::Value::Float(f) => out.push((path.clone(), *f)),
            toml::Value::Table(t) => {
                for (k, x) in t {
                    if path.is_empty() && k == "rule" {
                        continue;
                    }
                    path.push(k.clone());
                    walk(x, path, out);
                    path.pop();
                }
            }
            toml::Value::Array(a) => {
                if let Some(last) = path.last_mut() {
                    last.push_str("[]");
                }
                for x in a {
                    walk(x, path, out);
                }
                if let Some(last) = path.last_mut() {
                    last.truncate(last.len() - 2);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(value, &mut Vec::new(), &mut out);
    out
}

/// A value shown in an error: integers without a fraction, others as Rust prints them.
fn shown(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

impl RunConfig {
    /// Checks every numeric setting against its range ([`RANGES`]); the error names the field.
    pub(super) fn validate_ranges(&self) -> Result<(), ConfigError> {
        let value = toml::Value::try_from(self).map_err(|e| ConfigError::Invalid {
            field: "(settings)".into(),
            reason: format!("do not serialise to TOML: {e}"),
        })?;
        // In the order of the table (a run's own settings, the eye, the cortex, CMF-SIM), so
        // that of two settings out of range the one the other follows from is named.
        let mut fields: Vec<(usize, Vec<String>, f64, &Range)> = numeric_fields(&value)
            .into_iter()
            .filter_map(|(path, v)| {
                let parts: Vec<&str> = path.iter().map(String::as_str).collect();
                let range = range_of(&parts)?;
                let at = RANGES.iter().position(|r| r.key == range.key)?;
                Some((at, path, v, range))
            })
            .collect();
        fields.sort_by_key(|f| f.0);
        for (_, path, v, range) in fields {
            let above = if range.min_excluded {
                v > range.min
            } else {
                v >= range.min
            };
            if !(above && v <= range.max) {
                let must = if range.min_excluded && range.min == 0.0 {
                    format!("must be positive and at most {}", shown(range.max))
                } else {
                    let open = if range.min_excluded { '(' } else { '[' };
                    format!(
                        "must be in {open}{}, {}]",
                        shown(range.min),
                        shown(range.max)
                    )
                };
                return Err(ConfigError::Invalid {
                    field: path.join(".").replace("[]", ""),
                    reason: format!("{} {must} ({})", shown(v), range.what),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
