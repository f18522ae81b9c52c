//! The presets: named sets of every setting of a run, one table. `quick` is the CPU eye
//! (64×64 foveated cones) and cortex in natural surface scenes; `main` (the default of `run`)
//! and `long` are the same eye and cortex trained longer; `large` is the quick cortex on an eye
//! of 128×128 cones, trained as long as `long`, for the questions the quick eye's cones are too
//! few to carry (a narrow fourth dimension).

use super::{ConfigError, RunConfig, Schedule};
use crate::observer::ObserverSettings;
use colorimetry::cmf_sim::CmfSimSettings;
use cortex::CortexConfig;
use retina::RetinaConfig;

/// The named sets of settings, in the order the help lists them.
pub const PRESETS: [&str; 7] = ["tiny", "quick", "main", "long", "large", "sandbox", "paper"];

/// Steps of the `long` preset: the quick eye trained until the convergence study (three seeds;
/// docs/notebook/2026-11-24-a-learned-cortex-converging.md) finds its held-out prediction gain
/// flat (10–11 from 16 000 steps on) and the learned invariants settled (C recall ≥ 0.97, P
/// 0.3–0.4 cone spacings). Its CMF-SIM dimension is not settled there: from 24 000 to 40 000 steps the seeds'
/// checkpoints fall on either side of the border between 2 and 3.
pub const LONG_STEPS: u64 = 40_000;

/// Steps of the `main` preset, the run of `cargo run --release`: fixed before the runs that
/// measured it (docs/notebook/2026-11-28-slow-colour-protocol-2.md), the quick eye in natural
/// surface scenes is 3-D at this length for each of arm B1's five seeds (K2 fails 1.06–3.08;
/// docs/notebook/2026-11-28-why-colour-emerged-slowly.md), and the run stays within half an
/// hour on 2 cores including the build.
pub const MAIN_STEPS: u64 = 12_000;

impl RunConfig {
    /// The named preset with `cones`.
    pub fn preset(name: &str, cones: &str) -> Result<RunConfig, ConfigError> {
        let invalid = |reason: String| ConfigError::Invalid {
            field: "preset".into(),
            reason,
        };
        if !PRESETS.contains(&name) {
            return Err(invalid(format!(
                "`{name}` is not one of {}",
                PRESETS.join(", ")
            )));
        }
        // `long` and `main` are the quick eye and cortex, `long` trained until prediction and
        // invariants plateau.
        let eye = if matches!(name, "long" | "main") {
            "quick"
        } else {
            name
        };
        let mut retina = RetinaConfig::preset(eye).map_err(|e| invalid(e.to_string()))?;
        retina.cones = cones.to_string();
        let mut cortex = CortexConfig::preset(eye).map_err(|e| invalid(e.to_string()))?;
        if matches!(name, "long" | "large") {
            cortex.train.checkpoint_every_steps = 2000;
        }
        if matches!(eye, "quick" | "large") {
            // The quick run uses the oracle eye motion (announced in its output), which keeps
            // it inside its time budget: the learned estimator (`[cortex.m] mode = "learned"`,
            // `oracle_motion = false` in a config file) trains stably since the gauge term
            // (cortex::buckets::m::gauge) but costs ~50 % more per step.
            cortex.m.mode = cortex::config::MMode::Oracle;
        }
        let (steps, cmf_sim, schedule) = measurement_plan(name, eye);
        // One setting: the run's `steps` is the cortex's.
        cortex.train.steps = steps;
        Ok(RunConfig {
            preset: name.to_string(),
            cones: cones.to_string(),
            seed: 0,
            steps,
            oracle_motion: matches!(cortex.m.mode, cortex::config::MMode::Oracle),
            oracle_w_start: false,
            learning_rule: cortex::RuleName::default(),
            rule: cortex::RuleSettings::new(),
            retina,
            cortex,
            cmf_sim,
            observer: ObserverSettings {
                // The 32-cone eye needs a larger patch for enough cones inside it (radius
                // 12.8 px of 64, about 6 cones) — the ladder's S-cone rungs fail at 1/8.
                patch_radius_fraction: if name == "tiny" { 0.2 } else { 0.125 },
                ..ObserverSettings::default()
            },
            schedule,
        })
    }
}

/// The steps, the CMF-SIM budget and the schedule of measurements of preset `name` on `eye`.
fn measurement_plan(name: &str, eye: &str) -> (u64, CmfSimSettings, Schedule) {
    let (steps, cmf_every, sets_per_k, wavelengths, pairs) = match name {
        // tiny: the calibration ladder (crate::ladder) returns every known answer up to
        // 3-D on this eye with 4 location pairs and 20 sets per K (with 2 pairs and 8
        // sets an LMS cone-activation observer measured 2-D); the 32² eye cannot carry a
        // fourth class (its tetrachromat oracles fail K = 4 at 3–4 of 5 seeds).
        "tiny" => (300, 0, 20, 30, 4),
        "sandbox" => (3000, 1000, 20, 50, 4),
        "paper" => (100_000, 10_000, 100, 100, 8),
        // long: the quick eye trained as long as the convergence study says (see
        // LONG_STEPS), with the small budget every 8 000 steps; large: the quick cortex on 4×
        // the cones, trained and measured the same way.
        "long" | "large" => (LONG_STEPS, 8000, 100, 100, 8),
        "main" => (MAIN_STEPS, 0, 100, 100, 8),
        // quick: CMF-SIM at the end with a paper-like budget (100 wavelengths as the paper;
        // 8 location pairs, chosen here: docs/references.md#cmf-sim-defaults, the authors'
        // CMF-SIM is not public; 100 sets per K, the paper used 500): 1.5–4 min on a trained quick cortex. During training a
        // smaller budget (below) draws the dimension over steps (Fig. 3.3).
        _ => (6000, 1500, 100, 100, 8),
    };
    // Early measurements catch the growth of the dimension (paper Fig. 3.3: 1-D, 2-D, 3-D);
    // `main` measures at log-spaced steps, about once per doubling of the step count.
    let extra_steps = match name {
        "quick" => vec![50, 100, 250, 500],
        "main" => vec![50, 100, 250, 500, 1000, 2000, 4000, 8000],
        "long" | "large" => vec![50, 100, 250, 500, 1000, 2000, 4000],
        _ => Vec::new(),
    };
    // The budget during training: each measurement should stay near a minute. 30 sets per
    // K: with 5, a quick MS dichromat's K = 2 failed by chance (its 10th set passed): too
    // few sets overstate the dimension.
    let (checkpoint_sets, checkpoint_wavelengths, checkpoint_pairs) = match eye {
        "quick" | "large" => (30, 50, 4),
        _ => (0, 0, 0),
    };
    let cmf_sim = CmfSimSettings {
        sets_per_k,
        n_test_wavelengths: wavelengths,
        location_pairs: pairs,
        max_primaries: 4,
        ..CmfSimSettings::default()
    };
    let schedule = Schedule {
        cmf_every_steps: cmf_every,
        cmf_extra_steps: extra_steps,
        pictures_every_steps: steps.max(1) / 4,
        eval_every_steps: (steps / 20).max(10),
        eval_batches: 4,
        held_out_scenes: match name {
            "tiny" => crate::invariants::TINY_HELD_OUT_SCENES,
            _ => crate::invariants::HELD_OUT_SCENES,
        },
        stop_at_dimension: 0,
        checkpoint_cmf_sets_per_k: checkpoint_sets,
        checkpoint_cmf_wavelengths: checkpoint_wavelengths,
        checkpoint_cmf_location_pairs: checkpoint_pairs,
    };
    (steps, cmf_sim, schedule)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_is_the_quick_eye_and_cortex_trained_to_their_plateau() {
        let quick = RunConfig::preset("quick", "LMS").unwrap();
        let long = RunConfig::preset("long", "LMS").unwrap();
        assert_eq!(
            (long.steps, long.cortex.train.steps),
            (LONG_STEPS, LONG_STEPS)
        );
        assert_eq!(long.retina, quick.retina);
        assert_eq!(
            (&long.cmf_sim, &long.observer),
            (&quick.cmf_sim, &quick.observer)
        );
        let mut cortex = long.cortex.clone();
        cortex.train.steps = quick.steps;
        cortex.train.checkpoint_every_steps = quick.cortex.train.checkpoint_every_steps;
        assert_eq!(cortex, quick.cortex);
        assert_eq!(long.cmf_settings(false), quick.cmf_settings(false));
        let e = RunConfig::preset("longer", "LMS").unwrap_err().to_string();
        assert!(
            e.contains("preset") && e.contains("`longer` is not one of tiny, quick, main, long"),
            "{e}"
        );
    }

    #[test]
    fn main_is_the_quick_eye_and_cortex_in_natural_scenes_trained_longer() {
        let quick = RunConfig::preset("quick", "LMS").unwrap();
        let main = RunConfig::preset("main", "LMS").unwrap();
        assert_eq!(
            (main.steps, main.cortex.train.steps),
            (MAIN_STEPS, MAIN_STEPS)
        );
        assert_eq!(main.retina, quick.retina, "the quick eye and its scenes");
        assert_eq!(
            (main.retina.scenes.generator, main.retina.scenes.tetra),
            (retina::scene::pool::SceneGenerator::Surfaces, None),
            "natural surface scenes, no S-07 tiles"
        );
        let mut cortex = main.cortex.clone();
        cortex.train.steps = quick.steps;
        assert_eq!(cortex, quick.cortex);
        assert_eq!(
            (&main.cmf_sim, &main.observer, main.oracle_motion),
            (&quick.cmf_sim, &quick.observer, quick.oracle_motion)
        );
        let at = &main.schedule.cmf_extra_steps;
        assert!(
            at.windows(2).all(|w| w[1] <= 2 * w[0] + w[0] / 2) && at.last() < Some(&MAIN_STEPS),
            "at most 2.5× apart, all before the end: {at:?}"
        );
        for one_class in ["L", "S"] {
            RunConfig::preset("main", one_class)
                .unwrap()
                .validate()
                .unwrap();
        }
    }

    #[test]
    fn large_is_the_long_training_of_the_quick_cortex_on_four_times_the_cones() {
        let long = RunConfig::preset("long", "LMSQ").unwrap();
        let large = RunConfig::preset("large", "LMSQ").unwrap();
        let (l, q) = (&large.retina, &long.retina);
        assert_eq!(
            (l.cones_per_side, l.field_px),
            (2 * q.cones_per_side, 2 * q.field_px)
        );
        assert_eq!(
            l.layout, q.layout,
            "the same foveation over the same visual field"
        );
        let shift_cones = |r: &RetinaConfig| {
            r.eye_motion.max_shift_px as f64 * r.cones_per_side as f64 / r.field_px as f64
        };
        assert_eq!(
            shift_cones(l),
            shift_cones(q),
            "eye motion in cone spacings"
        );
        assert!(l.scenes.tile_px >= l.field_px + 2 * l.eye_motion.max_shift_px as usize);
        assert_eq!(large.cortex, {
            let mut c = cortex::CortexConfig::large();
            c.train.steps = LONG_STEPS;
            c.train.checkpoint_every_steps = long.cortex.train.checkpoint_every_steps;
            c.m.mode = long.cortex.m.mode;
            c
        });
        assert_eq!(
            (
                large.steps,
                &large.cmf_sim,
                &large.observer,
                large.oracle_motion
            ),
            (
                long.steps,
                &long.cmf_sim,
                &long.observer,
                long.oracle_motion
            )
        );
        assert_eq!(large.schedule, long.schedule);
    }

    #[test]
    fn a_runs_summary_reads_the_converged_held_out_count_but_on_the_test_eye() {
        for preset in PRESETS {
            let c = RunConfig::preset(preset, "LMS").unwrap();
            let want = if preset == "tiny" { 32 } else { 1024 };
            assert_eq!(c.schedule.held_out_scenes, want, "{preset}");
        }
        // A config written before the setting existed reads what such runs read.
        let mut table: toml::Table =
            toml::from_str(&RunConfig::preset("main", "LMS").unwrap().to_toml()).unwrap();
        let schedule = table["schedule"].as_table_mut().unwrap();
        assert!(schedule.remove("held_out_scenes").is_some());
        let old: RunConfig = toml::from_str(&toml::to_string(&table).unwrap()).unwrap();
        assert_eq!(old.schedule.held_out_scenes, 32);
    }

    #[test]
    fn every_preset_resolves_and_round_trips_through_toml() {
        for preset in PRESETS {
            let c = RunConfig::preset(preset, "LMS").unwrap();
            c.validate().unwrap();
            let back: RunConfig = toml::from_str(&c.to_toml()).unwrap();
            assert_eq!(back, c, "{preset}");
        }
    }
}
