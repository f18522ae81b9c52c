//! Known answers of the statistics, and the generators against held-out photographs.

use super::*;
use crate::config::RetinaConfig;
use crate::scene::pool::{SceneGenerator, ScenePool, ScenePoolConfig};
use crate::scene::projection::SceneProjection;
use colorimetry::{ConeClass, ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Two uniform halves of different colours, left and right: only the horizontal pairs that
/// cross the boundary differ, `size` of the `2·size·(size − d)` pairs at `d = 1`.
#[test]
fn two_halves_differ_only_across_their_boundary() {
    let n = 64;
    let plane = |left: f32, right: f32| -> Vec<f32> {
        (0..n * n)
            .map(|p| if p % n < n / 2 { left } else { right })
            .collect()
    };
    let s = measure_crop(&plane(1.0, 0.5), &plane(0.5, 1.0), &plane(0.2, 0.6), n);
    let want = 1.0 - n as f64 / (2 * n * (n - 1)) as f64;
    assert!(
        (s.same_colour[0] - want).abs() < 1e-12,
        "{} vs {want}",
        s.same_colour[0]
    );
    let d8 = 8.0 * n as f64 / (2 * n * (n - 8)) as f64;
    assert!((s.same_colour[5] - (1.0 - d8)).abs() < 1e-12);
    // Halves: the chromatic ratios are two-valued, correlated across any short distance;
    // L + M is the same on both sides, so the luminance contrast has no spectrum.
    assert!(s.red_green[0] > 0.9 && s.blue_yellow[0] > 0.9);
    assert!(s.spectral_slopes[0].is_nan() && s.spectral_slopes[1].is_finite());
    // The red–green ratio is ±a on the two halves (a = 0.5 / (L + M + ε), ε = 1e-3·⟨L + M⟩),
    // so its standard deviation is a, and only the crossing pairs differ, by 2a.
    let a = 0.5 / (1.5 + 1.5e-3);
    assert!(s.contrast_sd[0].abs() < 1e-12, "{:?}", s.contrast_sd);
    assert!((s.contrast_sd[1] - a).abs() < 1e-9, "{:?}", s.contrast_sd);
    for (i, &d) in DISTANCES_PX.iter().enumerate() {
        let crossing = (d * n) as f64 / (2 * n * (n - d)) as f64;
        let want = 2.0 * a * crossing.sqrt();
        let got = s.red_green_difference_rms[i];
        assert!((got - want).abs() < 1e-9, "d = {d}: {got} vs {want}");
    }
}

/// Independent random colours at every pixel: no correlation at any distance, and hardly
/// ever the same colour.
#[test]
fn white_noise_is_uncorrelated() {
    let n = 96;
    let mut rng = StdRng::seed_from_u64(3);
    let mut plane = || -> Vec<f32> { (0..n * n).map(|_| rng.random_range(0.2..1.0)).collect() };
    let (l, m, s) = (plane(), plane(), plane());
    let st = measure_crop(&l, &m, &s, n);
    for (name, curve) in st.curves().into_iter().take(3) {
        assert!(curve.iter().all(|r| r.abs() < 0.05), "{name}: {curve:?}");
    }
    assert!(
        st.same_colour.iter().all(|&v| v < 0.1),
        "{:?}",
        st.same_colour
    );
    // Independent points differ by √2 standard deviations at every distance.
    for &v in &st.red_green_difference_rms {
        let ratio = v / (st.contrast_sd[1] * 2f64.sqrt());
        assert!((ratio - 1.0).abs() < 0.03, "{ratio}");
    }
    // White noise has a flat spectrum.
    assert!(
        st.spectral_slopes.iter().all(|s| s.abs() < 0.3),
        "{:?}",
        st.spectral_slopes
    );
}

/// The measured photographs' statistics (`retina/data/photo_statistics.json`, made by
/// `retina/examples/scene_statistics.rs`): `(held_out, statistics)` per photograph.
fn photographs() -> Vec<(bool, SpatialStatistics)> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/photo_statistics.json");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    doc["photos"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let s = serde_json::from_value(p["statistics"].clone()).unwrap();
            (p["held_out"].as_bool().unwrap(), s)
        })
        .collect()
}

/// The mean statistics of 16 tiles of `generator` (its default settings), as training tiles.
fn generator(generator: SceneGenerator) -> SpatialStatistics {
    let grid = WavelengthGrid::default();
    let proj = SceneProjection::new(&ConeClass::lms(), &ConeTemplate::default(), &grid).unwrap();
    let cfg = ScenePoolConfig {
        tiles: 1,
        tile_px: CROP_PX,
        generator,
        tetra: None,
        refresh_every_batches: 0,
        ..RetinaConfig::quick().scenes
    };
    let pool = ScenePool::new(cfg, proj, 1, &mut StdRng::seed_from_u64(5)).unwrap();
    let mut rng = StdRng::seed_from_u64(6);
    let all: Vec<SpatialStatistics> = (0..16)
        .map(|i| {
            let p = pool.make_planes(i, &mut rng).unwrap();
            measure_image(&p.planes, p.h, p.w).unwrap()
        })
        .collect();
    SpatialStatistics::mean(&all)
}

/// Widening of the held-out photographs' range at each distance, for the generator's
/// sampling noise (16 tiles).
const ENVELOPE_MARGIN: f64 = 0.05;

/// The largest distance, over the four curves and ten distances, by which `s` lies outside
/// the range of the held-out photographs; with where.
fn excess(s: &SpatialStatistics, held: &[&SpatialStatistics]) -> (f64, String) {
    let mut worst = (f64::NEG_INFINITY, String::new());
    for c in 0..4 {
        for (i, d) in DISTANCES_PX.iter().enumerate() {
            let vals: Vec<f64> = held.iter().map(|h| h.curves()[c].1[i]).collect();
            let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let v = s.curves()[c].1[i];
            let e = (lo - v).max(v - hi);
            if e > worst.0 {
                worst = (
                    e,
                    format!(
                        "{} at {d} px: {v:.2} against [{lo:.2}, {hi:.2}]",
                        s.curves()[c].0
                    ),
                );
            }
        }
    }
    worst
}

/// The surfaces generator lies within the held-out photographs' range (± 0.05) at every
/// distance of every curve, and its spectral slopes within theirs; the classic dead leaves
/// do not (their colour and luminance decorrelate within a few cones).
#[test]
fn surfaces_match_held_out_photographs_and_classic_dead_leaves_do_not() {
    let photos = photographs();
    let held: Vec<&SpatialStatistics> = photos.iter().filter(|p| p.0).map(|p| &p.1).collect();
    assert!(
        held.len() >= 5 && photos.len() >= 3 * held.len() - 2,
        "{} held out of {}",
        held.len(),
        photos.len()
    );
    let surfaces = generator(SceneGenerator::Surfaces);
    let (e, at) = excess(&surfaces, &held);
    assert!(
        e <= ENVELOPE_MARGIN,
        "surfaces outside the held-out photographs by {e:.3}: {at}"
    );
    for c in 0..3 {
        let lo = held
            .iter()
            .map(|h| h.spectral_slopes[c])
            .fold(f64::INFINITY, f64::min);
        let hi = held
            .iter()
            .map(|h| h.spectral_slopes[c])
            .fold(f64::NEG_INFINITY, f64::max);
        let v = surfaces.spectral_slopes[c];
        assert!(
            v >= lo && v <= hi,
            "spectral slope {c}: {v:.2} outside [{lo:.2}, {hi:.2}]"
        );
    }
    let classic = generator(SceneGenerator::DeadLeaves);
    let (e, at) = excess(&classic, &held);
    assert!(
        e > 2.0 * ENVELOPE_MARGIN,
        "classic dead leaves only {e:.3} outside: {at}"
    );
    // Not fitted: how far the L − M balance moves between two points. The surfaces' lies in
    // the held-out photographs' range at every distance; the classic dead leaves' at one cone
    // (2 px) is well above every held-out photograph's.
    let range = |i: usize| {
        let v = held.iter().map(|h| h.red_green_difference_rms[i]);
        (
            v.clone().fold(f64::INFINITY, f64::min),
            v.fold(f64::NEG_INFINITY, f64::max),
        )
    };
    for (i, d) in DISTANCES_PX.iter().enumerate() {
        let (lo, hi) = range(i);
        let v = surfaces.red_green_difference_rms[i];
        assert!(
            v >= lo && v <= hi,
            "surfaces' red-green difference at {d} px: {v:.4} outside [{lo:.4}, {hi:.4}]"
        );
    }
    let one_cone = distance_index(NEIGHBOUR_CONES_PX);
    let (_, hi) = range(one_cone);
    let v = classic.red_green_difference_rms[one_cone];
    assert!(
        v > 1.5 * hi,
        "classic dead leaves' red-green difference at 2 px {v:.4}, held-out photographs ≤ {hi:.4}"
    );
}
