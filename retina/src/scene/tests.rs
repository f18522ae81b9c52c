//! Spectral dimensionality and spatial statistics of the scenes; pool
//! mechanics.

use super::dead_leaves::{DeadLeavesConfig, LeafScene};
use super::library::ReflectanceLibrary;
use super::pool::{RgbPath, SceneGenerator, ScenePool, ScenePoolConfig, SceneProjection, TetraMix};
use super::rgb::{Display, RgbImage};
use super::surfaces::SurfacesConfig;
use super::tetra::TetraEnvironment;
use super::*;
use crate::analysis::{pca_components_for_variance, power_spectrum_slope};
use colorimetry::{ConeClass, ConeTemplate};
use rand::rngs::StdRng;
use rand::SeedableRng;

/// L, M, S and `q`: a tetrachromat's classes.
pub(crate) fn lms_plus(q: ConeClass) -> Vec<ConeClass> {
    vec![ConeClass::l(), ConeClass::m(), ConeClass::s(), q]
}

/// A synthetic pool of `tiles` tiles of `tile_px`, white balanced, never refreshed.
fn pool_config(tiles: usize, tile_px: usize, tetra: Option<TetraMix>) -> ScenePoolConfig {
    ScenePoolConfig {
        tiles,
        tile_px,
        generator: SceneGenerator::DeadLeaves,
        dead_leaves: DeadLeavesConfig::default(),
        surfaces: SurfacesConfig::default(),
        tetra,
        files: vec![],
        rgb_path: RgbPath::Display,
        white_balance: true,
        q_from_lms: None,
        refresh_every_batches: 0,
        file_scale: Default::default(),
        mat: Default::default(),
        band_stack: Default::default(),
        cache_dir: None,
    }
}

/// Standard deviation over pixels of ln(Q / L) in `(≥ 4, nn)` planes whose planes 0 and 3 are
/// L and Q: the contrast only a tetrachromat sees, independent of shading.
pub(crate) fn q_over_l_contrast(planes: &[f32], nn: usize) -> f64 {
    let v: Vec<f64> = (0..nn)
        .filter(|&p| planes[p] > 1e-6 && planes[3 * nn + p] > 1e-6)
        .map(|p| (planes[3 * nn + p] as f64 / planes[p] as f64).ln())
        .collect();
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

/// Each pixel's spectrum divided by its Euclidean norm (spectral shape; shading removed).
fn normalise_spectra(img: &SpectralImage) -> Vec<f32> {
    let (d, hw) = (img.grid.len(), img.h * img.w);
    let mut out = img.data.clone();
    for p in 0..hw {
        let norm = (0..d)
            .map(|l| img.data[l * hw + p].powi(2))
            .sum::<f32>()
            .sqrt();
        if norm > 0.0 {
            for l in 0..d {
                out[l * hw + p] /= norm;
            }
        }
    }
    out
}

fn astronaut() -> RgbImage {
    RgbImage::read_png(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/astronaut.png"))
        .unwrap()
}

#[test]
fn synthetic_scenes_need_at_least_six_components_rgb_scenes_three() {
    let g = WavelengthGrid::default();
    let lib = ReflectanceLibrary::measured(&g).unwrap();
    let cfg = DeadLeavesConfig {
        size_px: 256,
        ..DeadLeavesConfig::default()
    };
    for seed in 0..3 {
        let img = LeafScene::generate(&cfg, &lib, &mut StdRng::seed_from_u64(seed))
            .unwrap()
            .render_spectral(&lib);
        let shape = pca_components_for_variance(&normalise_spectra(&img), 31, 0.99);
        let raw = pca_components_for_variance(&img.data, 31, 0.99);
        eprintln!(
            "dead leaves seed {seed}: 99 % of variance needs {shape} components of spectral shape \
             (norm-normalised pixel spectra), {raw} of raw radiance"
        );
        assert!(shape >= 6, "seed {seed}: {shape}");
        // Raw radiance is dominated by shading, but still exceeds what RGB can carry.
        assert!(raw > 3, "seed {seed}: raw {raw}");
    }
    let d = Display::srgb_like(&g).unwrap();
    let img = d.spectral_image(&astronaut());
    let shape = pca_components_for_variance(&normalise_spectra(&img), 31, 0.99);
    let raw = pca_components_for_variance(&img.data, 31, 0.99);
    eprintln!("astronaut through the display: {shape} (shape), {raw} (raw) components");
    assert!(shape <= 3 && raw <= 3, "{shape} {raw}");
    // Rank 3: three components hold all the variance.
    assert!(pca_components_for_variance(&img.data, 31, 0.999_999) <= 3);
}

#[test]
fn synthetic_scenes_have_natural_power_spectra() {
    let g = WavelengthGrid::default();
    let lib = ReflectanceLibrary::measured(&g).unwrap();
    let xyz = Projector::xyz(&g).unwrap();
    let cfg = DeadLeavesConfig {
        size_px: 256,
        ..DeadLeavesConfig::default()
    };
    let mut slopes = vec![];
    for seed in 0..4 {
        let scene = LeafScene::generate(&cfg, &lib, &mut StdRng::seed_from_u64(seed)).unwrap();
        let y = &scene.render_projected(&lib, &xyz)[256 * 256..2 * 256 * 256];
        // 4 … 64 cycles per image (2 … 0.25 cycles/px is past the leaves' 1.5 px minimum).
        slopes.push(power_spectrum_slope(y, 256, 4.0, 0.5));
    }
    let mean = slopes.iter().sum::<f64>() / slopes.len() as f64;
    eprintln!("luminance power-spectrum slopes {slopes:.3?}, mean {mean:.3}");
    for s in &slopes {
        assert!((-2.4..=-1.6).contains(s), "slope {s}");
    }
}

#[test]
fn pool_white_balance_and_reference_planes() {
    let g = WavelengthGrid::default();
    let classes = lms_plus(ConeClass::human_q());
    let proj = SceneProjection::new(&classes, &ConeTemplate::default(), &g).unwrap();
    assert_eq!(proj.reference_lms, [0, 1, 2]);
    assert_eq!(proj.n_planes(), 4);
    for (w, want) in proj.white.iter().zip([1.083, 1.006, 0.520]) {
        assert!((w - want).abs() < 0.01, "{:?}", proj.white);
    }
    let cfg = pool_config(3, 48, None);
    let pool = ScenePool::new(cfg.clone(), proj.clone(), 2, &mut StdRng::seed_from_u64(0)).unwrap();
    for t in 0..3 {
        let stack = pool.tile(t);
        for (p, w) in proj.white.iter().enumerate() {
            let max = stack.plane(0, p).iter().copied().fold(0.0f32, f32::max);
            assert!(
                (max as f64 - w).abs() < 1e-5,
                "tile {t} plane {p}: {max} vs {w}"
            );
        }
    }
    // A dichromat lacks S: the reference S is appended as an extra plane.
    let ls = SceneProjection::new(
        &[ConeClass::l(), ConeClass::s()],
        &ConeTemplate::default(),
        &g,
    )
    .unwrap();
    assert_eq!(ls.reference_lms, [0, 2, 1]);
    assert_eq!(ls.plane_classes[2].name, "ref_M");
    // PNG files through the matrix path: not white balanced, exact official matrix.
    let png = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/astronaut.png");
    let cache = std::env::temp_dir().join(format!("pool-png-cache-{}", std::process::id()));
    let files = ScenePoolConfig {
        files: vec![png],
        rgb_path: RgbPath::Matrix,
        tiles: 1,
        cache_dir: Some(cache.clone()),
        ..cfg
    };
    let pool = ScenePool::new(files, proj, 1, &mut StdRng::seed_from_u64(0)).unwrap();
    let max_l = pool
        .tile(0)
        .plane(0, 0)
        .iter()
        .copied()
        .fold(0.0f32, f32::max);
    assert!(max_l <= 1.0831, "{max_l}");
    std::fs::remove_dir_all(&cache).unwrap();
}

/// A pool of four 64-px synthetic tiles for `classes`, with `tetra` patches.
fn synthetic_pool(
    tetra: Option<TetraMix>,
    classes: &[ConeClass],
) -> crate::error::Result<ScenePool> {
    let g = WavelengthGrid::default();
    let proj = SceneProjection::new(classes, &ConeTemplate::default(), &g).unwrap();
    ScenePool::new(
        pool_config(4, 64, tetra),
        proj,
        1,
        &mut StdRng::seed_from_u64(9),
    )
}

#[test]
fn a_hue_sphere_pool_holds_more_tetrachromatic_contrast_than_natural_scenes() {
    let classes = lms_plus(ConeClass::human_q());
    let hue = Some(TetraMix {
        environment: TetraEnvironment::HueSphere,
        fraction: 1.0,
        hue_rule: Default::default(),
    });
    let mean_contrast = |pool: &ScenePool| {
        let nn = 64 * 64;
        (0..4)
            .map(|t| {
                let planes: Vec<f32> = (0..4)
                    .flat_map(|p| pool.tile(t).plane(0, p).to_vec())
                    .collect();
                q_over_l_contrast(&planes, nn)
            })
            .sum::<f64>()
            / 4.0
    };
    let natural = mean_contrast(&synthetic_pool(None, &classes).unwrap());
    let hue_sphere = mean_contrast(&synthetic_pool(hue, &classes).unwrap());
    eprintln!("std ln(Q/L) per tile: natural {natural:.4}, hue sphere {hue_sphere:.4}");
    assert!(hue_sphere > natural, "{hue_sphere} vs {natural}");
    // A monochromat has no hue sphere: the pool says which setting is wrong.
    let err = synthetic_pool(hue, &[ConeClass::l()])
        .unwrap_err()
        .to_string();
    assert!(err.contains("scenes.tetra.environment"), "{err}");
}

/// The planes of tile draws `0..3` of a pigeon-Q pool with `q_from_lms` (seeded alike).
fn pigeon_q_draws(
    q_from_lms: Option<super::q_from_lms::QFromLms>,
) -> (ScenePool, Vec<ClassPlanes>) {
    let g = WavelengthGrid::default();
    let classes = lms_plus(ConeClass::pigeon_q());
    let proj = SceneProjection::new(&classes, &ConeTemplate::default(), &g).unwrap();
    let cfg = ScenePoolConfig {
        q_from_lms,
        ..pool_config(1, 48, None)
    };
    let pool = ScenePool::new(cfg, proj, 1, &mut StdRng::seed_from_u64(3)).unwrap();
    let mut rng = StdRng::seed_from_u64(4);
    let draws = (0..3)
        .map(|i| pool.make_planes(i, &mut rng).unwrap())
        .collect();
    (pool, draws)
}

#[test]
fn q_from_lms_replaces_only_the_q_plane_with_its_fixed_fit() {
    use super::q_from_lms::QFromLms;
    let (plain, before) = pigeon_q_draws(None);
    assert!(plain.q_from_lms_fit().is_none());
    let (pool, after) = pigeon_q_draws(Some(QFromLms::AfterBalance));
    let fit = *pool.q_from_lms_fit().unwrap();
    assert_eq!((fit.q_plane, fit.lms_planes), (3, [0, 1, 2]));
    let hw = 48 * 48;
    let mut changed = false;
    for (a, b) in before.iter().zip(&after) {
        // The same scene: L, M, S untouched ...
        assert_eq!(a.planes[..3 * hw], b.planes[..3 * hw]);
        // ... and Q exactly the fit's prediction from them.
        for i in 0..hw {
            let want = fit.predict([b.planes[i], b.planes[hw + i], b.planes[2 * hw + i]]);
            assert_eq!(b.planes[3 * hw + i], want);
        }
        changed |= a.planes[3 * hw..] != b.planes[3 * hw..];
    }
    assert!(changed, "natural Q is not exactly affine in L, M, S");
}

#[test]
fn q_from_lms_before_the_balance_is_affine_within_each_tile_only() {
    use super::q_from_lms::{QFromLms, QFromLmsFit};
    let (pool, draws) = pigeon_q_draws(Some(QFromLms::BeforeBalance));
    let fit = *pool.q_from_lms_fit().unwrap();
    // Within one tile Q is affine in the balanced L, M, S (a per-tile fit leaves nothing) ...
    let per_tile: Vec<QFromLmsFit> = draws
        .iter()
        .map(|d| {
            QFromLmsFit::fit(
                QFromLms::AfterBalance,
                std::slice::from_ref(d),
                3,
                [0, 1, 2],
            )
        })
        .collect();
    let hw = 48 * 48;
    for (d, f) in draws.iter().zip(&per_tile) {
        let worst = (0..hw)
            .map(|i| {
                let p = f.predict([d.planes[i], d.planes[hw + i], d.planes[2 * hw + i]]);
                (p - d.planes[3 * hw + i]).abs()
            })
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "per-tile residual {worst}");
    }
    // ... with coefficients that differ from tile to tile (the balance's gains).
    let c: Vec<[f64; 4]> = per_tile.iter().map(|f| f.coefficients).collect();
    assert!(
        c.windows(2).any(|w| (w[0][1] - w[1][1]).abs() > 1e-3),
        "{c:?}"
    );
    assert_eq!(fit.stage, QFromLms::BeforeBalance);
}

#[test]
fn q_from_lms_needs_a_q_class() {
    let g = WavelengthGrid::default();
    let proj = SceneProjection::new(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
    let cfg = ScenePoolConfig {
        q_from_lms: Some(super::q_from_lms::QFromLms::AfterBalance),
        ..pool_config(1, 48, None)
    };
    let err = ScenePool::new(cfg, proj, 1, &mut StdRng::seed_from_u64(3)).unwrap_err();
    assert!(err.to_string().contains("scenes.q_from_lms"), "{err}");
}
