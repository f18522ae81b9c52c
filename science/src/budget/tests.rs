//! The estimate's parts against their settings and measured peaks.

use super::*;

#[test]
fn every_part_grows_with_the_settings_that_drive_it() {
    let base = RunConfig::preset("quick", "LMS").unwrap();
    let e = estimate(&base, true, 2);
    let mut c = base.clone();
    c.retina.scenes.tiles *= 2;
    let pools = e.scenes_bytes - hidden_stream_bytes(&base);
    let doubled = estimate(&c, true, 2).scenes_bytes - hidden_stream_bytes(&c);
    assert!((doubled - 2.0 * pools).abs() < 1.0);
    let mut c = base.clone();
    c.cortex.train.batch_size *= 2;
    assert!((estimate(&c, true, 2).step_bytes - 2.0 * e.step_bytes).abs() < 1.0);
    assert_eq!(estimate(&base, false, 2).decode_bytes, 0.0);
    assert!(estimate(&base, true, 4).decode_bytes > e.decode_bytes);
    // A run's end reads `schedule.held_out_scenes`; a run without pictures reads none.
    assert!(e.held_out_bytes > 0.0);
    assert_eq!(
        e.held_out_bytes,
        held_out_bytes(&base, base.schedule.held_out_scenes)
    );
    let mut c = base.clone();
    c.schedule.held_out_scenes *= 2;
    assert!((estimate(&c, true, 2).held_out_bytes - 2.0 * e.held_out_bytes).abs() < 1.0);
    assert_eq!(without_pictures(&base, e).held_out_bytes, 0.0);
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
fn the_cmf_sim_part_grows_with_the_pairs_but_not_with_k_at_the_top() {
    let c = RunConfig::preset("tiny", "LMS").unwrap();
    let layout = layout(&c);
    let window = cmf_sim::decode_pixels(&c, &layout);
    let at = |pairs: usize| {
        let mut s = c.cmf_settings(true);
        s.location_pairs = pairs;
        cmf_sim::bytes(&c, &s, &layout, ObserverKind::Cortex, window)
    };
    // More pairs, more shows and cached locations.
    assert!(at(8) > at(4), "{} {}", at(4), at(8));
    // At the top the search is solved in groups that fit a fixed budget, so what it holds
    // stops growing with K: a cortex whose search ends at K = 1 is estimated as one that tries
    // K = 4, to within the one group's difference (docs/memory-tops.md).
    let mut top = c.clone();
    top.cmf_sim.location_pairs = 1024;
    let at_k = |k: usize| {
        let mut t = top.clone();
        t.cmf_sim.max_primaries = k;
        estimate_convergence(&t, true, 1, 32).total_bytes()
    };
    let group = colorimetry::cmf_sim::sets::SOLVE_GROUP_BYTES as f64;
    assert!(
        at_k(4) - at_k(1) < group,
        "{} {}",
        at_k(1) / MIB,
        at_k(4) / MIB
    );
}

#[test]
fn the_cmf_sim_part_counts_the_solvers_states_per_primary() {
    let c = RunConfig::preset("quick", "LMSQ,Q:506").unwrap();
    let layout = layout(&c);
    let window = cmf_sim::decode_pixels(&c, &layout);
    let s = c.cmf_settings(true);
    let rows = (s.n_test_wavelengths * s.location_pairs) as f64
        * cmf_sim::readout_len(&c, &layout, ObserverKind::Cortex) as f64;
    let at = |k: usize| {
        let mut s = s.clone();
        s.max_primaries = k;
        cmf_sim::bytes(&c, &s, &layout, ObserverKind::Cortex, window)
    };
    // Each primary more: two Jacobian columns in every state and two readouts a row in the
    // Jacobian pass, f64.
    assert!(at(4) - at(3) >= 4.0 * rows * 8.0, "{} {}", at(3), at(4));
    let mut off = s.clone();
    off.front_end_jacobians = false;
    assert!(cmf_sim::bytes(&c, &off, &layout, ObserverKind::Cortex, window) < at(s.max_primaries));
}

#[test]
fn a_quick_tetrachromat_reading_is_estimated_at_its_measured_peak() {
    // Measured (docs/memory-tops.md): one thread, `cmf-sim --run results/fourth-A0-seed21
    // --checkpoint-step 24000 --location-seed 0` (a `--preset main --cones LMSQ,Q:506`
    // checkpoint; D's decoder on the box of cells read): peak 375 MiB.
    let c = RunConfig::preset("main", "LMSQ,Q:506").unwrap();
    let m = crate::measure::measurement_config(&c);
    let e = estimate_cmf_sim(&m, ObserverKind::Cortex, 1).total_bytes() / MIB;
    assert!((375.0..=1.3 * 375.0).contains(&e), "{e:.0} MiB");
}

#[test]
fn a_paper_eye_reading_counts_the_cortexs_decode_window_not_the_field() {
    // The quick eye's patches need the whole 64² field; the 256² eye's a window (160² for most
    // patches in the observer; the largest, 200², is what the estimate counts), so its decodes
    // and location bases count less than the field's. Measured (docs/memory-tops.md): two threads, `cmf-sim --run
    // results/slow-colour-anchor-paper-seed0-10k --checkpoint-step 1000 --location-seed 0`,
    // peak 3 476 MiB; the estimate was 5 213 MiB (1.50×) when it counted the field, and is
    // 4 585 MiB (1.32×) with the window; the rest was the per-cone part fitted on the small
    // eyes' runs (17.4 KiB a cone, 1 114 MiB at 256²), where the eye takes 1.9 KiB a cone
    // beyond 64²: 3 655 MiB (1.05×).
    let quick = RunConfig::preset("main", "LMS").unwrap();
    let paper = RunConfig::preset("paper", "LMS").unwrap();
    let pixels = |c: &RunConfig| {
        let layout = layout(c);
        cmf_sim::decode_pixels(c, &layout)
    };
    assert_eq!(pixels(&quick), 64.0 * 64.0);
    let p = pixels(&paper);
    assert_eq!(p, 200.0 * 200.0);
    let m = crate::measure::measurement_config(&paper);
    let e = estimate_cmf_sim(&m, ObserverKind::Cortex, 2).total_bytes() / MIB;
    assert!((3476.0..=1.3 * 3476.0).contains(&e), "{e:.0} MiB");
}

#[test]
fn an_observer_without_a_cortex_is_estimated_by_its_own_readout() {
    // The analytic observer at the top of location_pairs: one value per class a show, no
    // decodes, no location cache, no front end, at most as many primaries as classes.
    // Measured (docs/memory-tops.md, `scripts/memory-tops.sh`): `cmf-sim --observer
    // analytic --preset tiny --set cmf_sim.location_pairs=4096` peaked at 227–239 MiB
    // resident. With the cortex's readout the estimate was 20 007 MiB, refusing the run.
    let mut c = RunConfig::preset("tiny", "LMS").unwrap();
    c.cmf_sim.location_pairs = 4096;
    let m = crate::measure::measurement_config(&c);
    let analytic = estimate_cmf_sim(&m, ObserverKind::Analytic, 1);
    let cortex = estimate_cmf_sim(&m, ObserverKind::Cortex, 1);
    assert_eq!(analytic.decode_bytes, 0.0);
    assert!(analytic.cmf_sim_bytes < cortex.cmf_sim_bytes / 10.0);
    let e = analytic.total_bytes() / MIB;
    assert!((239.0..=1.3 * 227.0).contains(&e), "{e:.0} MiB");
}

#[test]
fn the_scene_pools_are_estimated_at_their_measured_peaks() {
    // Measured (docs/memory-tops.md, one thread, `/usr/bin/time -v`): `simulate --preset
    // tiny --set retina.scenes.tiles=2000` peaked at 678 MiB (one pool); `run --preset tiny
    // --steps 1 --set retina.scenes.tiles=1000` at 702 MiB (two pools of 316 MiB and the
    // hidden-signal measures' stream of four tiles).
    let mut c = RunConfig::preset("tiny", "LMS").unwrap();
    c.retina.scenes.tiles = 2000;
    let eye = estimate_eye(&c).total_bytes() / MIB;
    assert!((678.0..=1.3 * 678.0).contains(&eye), "{eye:.0} MiB");
    c.retina.scenes.tiles = 1000;
    c.steps = 1;
    let run = estimate(&c, true, 1).total_bytes() / MIB;
    assert!((702.0..=1.3 * 702.0).contains(&run), "{run:.0} MiB");
    // A dichromat's scenes also carry the reference plane its eye lacks.
    let lm = RunConfig::preset("tiny", "LM").unwrap();
    let lms = RunConfig::preset("tiny", "LMS").unwrap();
    assert_eq!(
        estimate(&lm, true, 1).scenes_bytes,
        estimate(&lms, true, 1).scenes_bytes
    );
}

#[test]
fn average_counts_its_other_checkpoints_beside_a_measurement_with_cmf_sim() {
    let c = RunConfig::preset("quick", "LMSQ").unwrap();
    let with_cmf = estimate_convergence(&c, true, 2, c.schedule.held_out_scenes);
    let none = estimate_average(&c, 2, 0.0);
    assert_eq!(none.total_bytes(), with_cmf.total_bytes());
    assert!(!none.parts().contains("--steps"), "{}", none.parts());
    let three = estimate_average(&c, 2, 3.0 * MIB);
    assert_eq!(three.total_bytes(), with_cmf.total_bytes() + 3.0 * MIB);
    assert!(
        three
            .parts()
            .contains("the other checkpoints averaged 3 MiB (--steps)"),
        "{}",
        three.parts()
    );
}

#[test]
fn convergence_is_estimated_at_its_measured_peaks() {
    // Measured (one thread, `/usr/bin/time -f %M colorvision convergence --run DIR [--cmf]` on
    // a fresh `train --preset P --steps 20 --set cortex.train.checkpoint_every_steps=10`
    // folder, the default 1 024 held-out scenes at most 16 × 16 sites a scene; the largest of
    // repeated runs): `tiny` 123 MiB without CMF-SIM (113 to 123 over four folders) and 136
    // with it (127 to 136), `quick` 158 without (150 and 158). Every site inside the border,
    // before the sites were thinned: 341, 363 and 1 360.
    let c = RunConfig::preset("tiny", "LMS").unwrap();
    let scenes = crate::invariants::HELD_OUT_SCENES;
    let bare = estimate_convergence(&c, false, 1, scenes).total_bytes() / MIB;
    let with_cmf = estimate_convergence(&c, true, 1, scenes).total_bytes() / MIB;
    assert!((123.0..=1.3 * 123.0).contains(&bare), "{bare:.0} MiB");
    assert!(
        (136.0..=1.3 * 136.0).contains(&with_cmf),
        "{with_cmf:.0} MiB"
    );
    let q = RunConfig::preset("quick", "LMS").unwrap();
    let quick = estimate_convergence(&q, false, 1, scenes).total_bytes() / MIB;
    assert!((158.0..=1.3 * 158.0).contains(&quick), "{quick:.0} MiB");
    // The samples alone: the peak at 1 024 scenes less the peak at 8, measured 80.8–88.8 MiB
    // on `quick` (two folders).
    let few = estimate_convergence(&q, false, 1, 8).total_bytes() / MIB;
    assert!(
        (88.8..=1.3 * 88.8).contains(&(quick - few)),
        "{few:.0} MiB at 8 scenes, {quick:.0} at {scenes}"
    );
    // No training step, and one pool: half a run's two, without the hidden measures' stream.
    let study = estimate_convergence(&c, true, 1, 32);
    let run = estimate(&c, true, 1);
    assert_eq!(study.step_bytes, 0.0);
    let hidden = hidden_stream_bytes(&c);
    assert!(hidden > 0.0);
    assert!((study.scenes_bytes * RUN_SCENE_POOLS + hidden - run.scenes_bytes).abs() < 1.0);
    let quiet = without_pictures(&c, run.clone());
    assert!((quiet.scenes_bytes - study.scenes_bytes * RUN_SCENE_POOLS).abs() < 1.0);
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

#[test]
fn a_readings_fixed_part_is_the_fitted_one_up_to_the_quick_eye_and_the_eyes_slope_beyond() {
    // Up to 64² cones a reading's fixed part is the one its peaks were checked against, so the
    // small eyes' estimates do not move; beyond, each cone adds the eye's measured 1.9 KiB
    // (docs/memory-tops.md: `simulate` from `quick` to `paper`), not the fitted 17.4: at 256²,
    // 33 + 17.4 × 4 096 / 1 024 + 1.9 × 61 440 / 1 024 = 217 MiB, not 33 + 17.4 × 64 = 1 147.
    for n in [16.0f64, 32.0, 64.0] {
        assert_eq!(
            reading_fixed_bytes(n * n),
            READING_FIXED_BYTES + READING_PER_CONE_BYTES_UP_TO_QUICK * n * n
        );
    }
    let paper_mib = reading_fixed_bytes(256.0 * 256.0) / MIB;
    let fitted_mib = (READING_FIXED_BYTES + READING_PER_CONE_BYTES_UP_TO_QUICK * 65536.0) / MIB;
    assert!((216.0..218.0).contains(&paper_mib), "{paper_mib:.1} MiB");
    assert!(
        (1146.0..1148.0).contains(&fitted_mib),
        "{fitted_mib:.1} MiB"
    );
    // The eye alone measured 238.7 MiB at 256² (`simulate --preset paper`, scenes included).
    assert!(paper_mib < 238.7);
}

#[test]
fn the_eye_alone_is_estimated_at_its_measured_peaks_at_every_size() {
    // Measured (docs/memory-tops.md, two threads, `/usr/bin/time -f %M colorvision simulate
    // --preset P`; the higher of two runs where two were taken): the eye alone grows by about 1.9 KiB a cone, not a training run's 8.0 or a reading's 17.4 up to 64², so
    // the estimate must bound the peak within 1.3 × from 32² to 256² cones.
    for (preset, peak_mib) in [
        ("tiny", 40.2),
        ("quick", 83.5),
        ("large", 120.8),
        ("paper", 238.9),
    ] {
        let c = RunConfig::preset(preset, "LMS").unwrap();
        let e = estimate_eye(&c).total_bytes() / MIB;
        assert!(
            (peak_mib..=1.3 * peak_mib).contains(&e),
            "{preset}: estimated {e:.1} MiB, peak {peak_mib} MiB"
        );
    }
}
