//! The retina uses the colorimetry templates, is linear in the scene, and batches correctly.
//! The spiking path is tested in `movie.rs`, through `Retina::movie` and `Retina::spikes`.

use super::*;
use crate::cones::NoiseConfig;
use crate::config::{GridConfig, RetinaConfig};
use crate::foveation::LayoutConfig;
use crate::scene::dead_leaves::{DeadLeavesConfig, LeafScene};
use crate::scene::library::ReflectanceLibrary;
use rand::rngs::StdRng;

fn tiny(cones: &str) -> Retina {
    let mut c = RetinaConfig::tiny();
    c.cones = cones.into();
    Retina::new(c).unwrap()
}

#[test]
fn retina_sensitivities_are_the_colorimetry_templates_with_official_peaks() {
    for (cones, peaks) in [
        ("LMS", vec![567.0, 536.0, 442.0]),
        ("LMSQ", vec![567.0, 536.0, 442.0, 552.0]),
        ("LMSQ,Q:506", vec![567.0, 536.0, 442.0, 514.0]),
    ] {
        let mut c = RetinaConfig::tiny();
        c.cones = cones.into();
        c.grid = GridConfig {
            start_nm: 400.0,
            end_nm: 700.0,
            step_nm: 1.0,
        };
        let r = Retina::new(c).unwrap();
        for (i, want) in peaks.iter().enumerate() {
            let got = r.fundamentals.effective_peak_nm(i);
            assert!(
                (got - want).abs() <= 1.0,
                "{cones} class {i}: peak {got} vs {want}"
            );
        }
        // The scene projector is those same curves times Δλ (1 nm here).
        let proj = &r.pool.projection.projector;
        let nl = r.fundamentals.n_wavelengths();
        for cidx in 0..r.mosaic.n_classes() {
            for l in 0..nl {
                let f = r.fundamentals.get(l, cidx) as f32;
                assert!((proj.matrix[cidx * nl + l] - f).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn batch_has_the_documented_shapes_and_is_reproducible() {
    let mut r = tiny("LMS");
    let mut rng = StdRng::seed_from_u64(9);
    let b = r.batch(&mut rng, 8);
    assert_eq!(b.signal.ons.len(), 8 * 2 * 32 * 32);
    assert_eq!((b.signal.n, b.signal.batch), (32, 8));
    assert_eq!(b.signal.oracle_motion, None, "the eye sends only the ONS");
    b.signal.validate().unwrap();
    assert_eq!(b.truth.oracle_shift_px.len(), 8);
    for (d, dn) in b
        .truth
        .oracle_shift_px
        .iter()
        .zip(&b.truth.oracle_shift_normalised)
    {
        assert!(d.iter().all(|v| (-2..=1).contains(v)), "{d:?}");
        assert_eq!(dn[0], d[0] as f32 / 32.0);
    }
    let mut r2 = tiny("LMS");
    let b2 = r2.batch(&mut StdRng::seed_from_u64(9), 8);
    assert_eq!(b, b2);
    let b3 = r.batch(&mut rng, 8);
    assert_ne!(b.signal.ons, b3.signal.ons);
}

#[test]
fn frame_one_is_the_scene_moved_by_the_oracle_shift() {
    // Identity layout, no LI, no noise, one cone class: frame 1 at (y, x) equals frame 0 at
    // (y + dy, x + dx).
    let mut c = RetinaConfig::sandbox();
    c.cones = "L".into();
    c.noise = NoiseConfig::off();
    c.scenes.tiles = 2;
    let mut r = Retina::new(c).unwrap();
    let b = r.batch(&mut StdRng::seed_from_u64(1), 4);
    let n = 64i32;
    for s in 0..4 {
        let [dx, dy] = b.truth.oracle_shift_px[s];
        let (f0, f1) = (b.signal.frame(s, 0), b.signal.frame(s, 1));
        let mut checked = 0;
        for y in 0..n {
            for x in 0..n {
                let (yy, xx) = (y + dy, x + dx);
                if (0..n).contains(&yy) && (0..n).contains(&xx) {
                    assert_eq!(f1[(y * n + x) as usize], f0[(yy * n + xx) as usize]);
                    checked += 1;
                }
            }
        }
        assert!(checked > 40 * 40);
    }
}

#[test]
fn noise_free_analog_ons_is_linear_in_the_scene() {
    for preset in [RetinaConfig::tiny(), RetinaConfig::sandbox()] {
        let r = Retina::new(RetinaConfig {
            cones: "LMSQ".into(),
            ..preset
        })
        .unwrap();
        let grid = r.pool.projection.grid.clone();
        let lib = ReflectanceLibrary::measured(&grid).unwrap();
        let cfg = DeadLeavesConfig {
            size_px: r.config.field_px,
            ..DeadLeavesConfig::default()
        };
        let mut rng = StdRng::seed_from_u64(5);
        let s1 = LeafScene::generate(&cfg, &lib, &mut rng)
            .unwrap()
            .render_spectral(&lib);
        let s2 = LeafScene::generate(&cfg, &lib, &mut rng)
            .unwrap()
            .render_spectral(&lib);
        let (a, b) = (0.7f32, -1.3f32);
        let mut mix = s1.clone();
        for (m, v) in mix.data.iter_mut().zip(&s2.data) {
            *m = a * *m + b * v;
        }
        let (o1, o2, om) = (
            r.encode_spectral(&s1).unwrap(),
            r.encode_spectral(&s2).unwrap(),
            r.encode_spectral(&mix).unwrap(),
        );
        let scale = o1.iter().chain(&o2).fold(0.0f32, |m, v| m.max(v.abs()));
        let err = om
            .iter()
            .zip(o1.iter().zip(&o2))
            .map(|(m, (x, y))| (m - (a * x + b * y)).abs())
            .fold(0.0f32, f32::max);
        eprintln!(
            "{}: linearity max error / max |ONS| = {:.2e}",
            r.config.name,
            err / scale
        );
        assert!(
            err <= 1e-5 * scale,
            "{}: {err} vs scale {scale}",
            r.config.name
        );
    }
}

#[test]
fn ground_truth_matches_the_batch() {
    let mut c = RetinaConfig::tiny();
    c.noise = NoiseConfig::off();
    c.lateral_inhibition = None;
    let mut r = Retina::new(c).unwrap();
    let b = r.batch(&mut StdRng::seed_from_u64(2), 3);
    // Without LI and noise, the ONS is Σ_k w_k · excitation_k at each cone.
    let ex = r.class_excitations_at_cones(&b.truth, 1);
    assert_signal_is_weighted_excitation(&r, &b, &ex, 1);
    let nn = 32 * 32;
    // sRGB ground truth: white-balanced scenes are bright and in a sane range.
    let rgb = r.srgb_at_cones(&b.truth, 0);
    assert_eq!(rgb.len(), 3 * 3 * nn);
    let mean = rgb.iter().sum::<f32>() / rgb.len() as f32;
    assert!(mean > 0.02 && mean < 1.0, "{mean}");
    assert!(r.dog_kernel().is_none());
    assert!(matches!(r.config.layout, LayoutConfig::Foveated(_)));
}

/// A batch's truth is the scene its signal was made from even after later batches have
/// refreshed every slot of the pool: read late, it equals what it was when the batch was drawn,
/// and it still explains the batch's noise-free signal.
#[test]
fn ground_truth_outlives_pool_refreshes() {
    let mut c = RetinaConfig::tiny();
    c.noise = NoiseConfig::off();
    c.lateral_inhibition = None;
    c.scenes.tiles = 2;
    c.scenes.refresh_every_batches = 1;
    let mut r = Retina::new(c).unwrap();
    let mut rng = StdRng::seed_from_u64(5);
    let first = r.batch(&mut rng, 3);
    let (ex_then, rgb_then) = (
        r.class_excitations_at_cones(&first.truth, 0),
        r.srgb_at_cones(&first.truth, 0),
    );
    for _ in 0..4 {
        r.batch(&mut rng, 3);
    }
    // Every slot now holds another tile: the pool no longer has the first batch's scenes.
    for s in 0..3 {
        let slot = first.truth.tiles[s];
        assert!(
            *r.pool.tile(slot) != *first.truth.stacks[s].0,
            "slot {slot} not refreshed"
        );
    }
    assert_eq!(r.class_excitations_at_cones(&first.truth, 0), ex_then);
    assert_eq!(r.srgb_at_cones(&first.truth, 0), rgb_then);
    assert_signal_is_weighted_excitation(&r, &first, &ex_then, 0);
}

/// Frame `frame` of every sample of `b` (a noise-free `tiny` eye without lateral inhibition,
/// 32 × 32 cones of 3 classes) is Σ_k w_k · excitation_k at each cone, `ex` being
/// [`Retina::class_excitations_at_cones`] of that frame.
fn assert_signal_is_weighted_excitation(r: &Retina, b: &EyeBatch, ex: &[f32], frame: usize) {
    let (nn, k) = (32 * 32, 3);
    for s in 0..b.signal.batch {
        for i in 0..nn {
            let want: f32 = (0..k)
                .map(|c| r.mosaic.weights[i * k + c] * ex[(s * k + c) * nn + i])
                .sum();
            assert!((b.signal.frame(s, frame)[i] - want).abs() < 1e-6);
        }
    }
}
#[test]
fn invalid_configs_are_errors_naming_the_setting() {
    let mut c = RetinaConfig::tiny();
    c.scenes.tile_px = 40;
    let e = Retina::new(c).unwrap_err().to_string();
    assert!(e.contains("scenes.tile_px"), "{e}");
    let e = Retina::preset("huge", "LMS").unwrap_err().to_string();
    assert!(e.contains("preset"), "{e}");
    let e = Retina::preset("tiny", "LMX").unwrap_err().to_string();
    assert!(e.contains("cones"), "{e}");
}
