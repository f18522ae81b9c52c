//! Preparation of scene files for a pool: the authors' steps, the cache, progress, the order
//! tiles walk the files in, and errors before any tile is made.

use std::sync::Mutex;

use colorimetry::{ConeClass, ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::SeedableRng;

use super::*;
use crate::scene::dead_leaves::DeadLeavesConfig;
use crate::scene::mat_io::{read_scene_mat, MatOptions};
use crate::scene::pool::{RgbPath, ScenePool};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/scenes")
}

fn temp_cache(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prepared-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn lms() -> SceneProjection {
    SceneProjection::new(
        &ConeClass::lms(),
        &ConeTemplate::default(),
        &WavelengthGrid::default(),
    )
    .unwrap()
}

fn config(files: Vec<PathBuf>, tiles: usize, tile_px: usize, cache: &Path) -> ScenePoolConfig {
    ScenePoolConfig {
        tiles,
        tile_px,
        generator: Default::default(),
        dead_leaves: DeadLeavesConfig::default(),
        surfaces: Default::default(),
        tetra: None,
        files,
        rgb_path: RgbPath::Display,
        white_balance: true,
        q_from_lms: None,
        refresh_every_batches: 1,
        file_scale: FileScale::Tile,
        mat: MatOptions::default(),
        band_stack: Default::default(),
        cache_dir: Some(cache.to_path_buf()),
    }
}

/// One progress report: `(done, total, file name, from cache)`.
type Report = (usize, usize, String, bool);

/// Prepare, recording every progress report.
fn prepare_logged(
    cfg: &ScenePoolConfig,
    proj: &SceneProjection,
) -> (Result<PreparedScenes>, Vec<Report>) {
    let log = Mutex::new(vec![]);
    let r = PreparedScenes::prepare(cfg, proj, None, &|p| {
        let name = p.path.file_name().unwrap().to_string_lossy().into_owned();
        log.lock()
            .unwrap()
            .push((p.done, p.total, name, p.from_cache));
    });
    let mut log = log.into_inner().unwrap();
    log.sort();
    (r, log)
}

#[test]
fn a_folder_is_prepared_once_and_then_read_from_the_cache() {
    let cache = temp_cache("folder");
    let proj = lms();
    let cfg = config(vec![fixtures().join("scenes")], 2, 96, &cache);
    let (first, log) = prepare_logged(&cfg, &proj);
    let first = first.unwrap();
    assert_eq!(first.len(), 3);
    assert_eq!(
        log.iter().map(|l| (l.0, l.1, l.3)).collect::<Vec<_>>(),
        [(1, 3, false), (2, 3, false), (3, 3, false)]
    );
    // 40 × 48 px photographs: short side brought to the 96-px tile.
    assert!(first.scenes.iter().all(|s| (s.h, s.w) == (96, 115)));
    let (second, log) = prepare_logged(&cfg, &proj);
    assert_eq!(second.unwrap().scenes, first.scenes);
    assert!(
        log.iter().all(|l| l.3),
        "second run re-read a cube: {log:?}"
    );
    // Another tile size is another eye: prepared anew.
    let (_, log) = prepare_logged(&config(cfg.files.clone(), 2, 100, &cache), &proj);
    assert!(log.iter().all(|l| !l.3), "{log:?}");
    std::fs::remove_dir_all(&cache).unwrap();
}

#[test]
fn prepared_planes_are_the_authors_steps_on_the_read_cube() {
    let cache = temp_cache("steps");
    let proj = lms();
    let file = fixtures().join("scenes/ARAD_1K_0002.mat");
    let cfg = config(vec![file.clone()], 1, 96, &cache);
    let prepared = PreparedScenes::prepare(&cfg, &proj, None, &|_| {}).unwrap();
    let got = prepared.planes(0, &proj).unwrap();
    // Independently: read, project, resize the short side to the tile, balance per image.
    let img = read_scene_mat(&file, &MatOptions::default(), &proj.grid).unwrap();
    let p = proj.project(&img);
    let data = crate::scene::resize::resize(&p.planes, p.n_planes, p.h, p.w, 96, 115);
    let mut want = proj.wrap(96, 115, data);
    want.white_balance(&proj.white);
    assert_eq!(got, want);
    // Each plane's brightest pixel is that class's response to the sRGB white.
    for (c, w) in proj.white.iter().enumerate() {
        let max = got.plane(c).iter().copied().fold(0.0f32, f32::max);
        assert!((max as f64 - w).abs() < 1e-5, "plane {c}: {max} vs {w}");
    }
    std::fs::remove_dir_all(&cache).unwrap();
}

#[test]
fn tiles_walk_every_file_before_any_is_used_again() {
    let cache = temp_cache("order");
    let cfg = config(vec![fixtures().join("scenes")], 2, 96, &cache);
    let mut pool = ScenePool::new(cfg, lms(), 1, &mut StdRng::seed_from_u64(3)).unwrap();
    let draws: Vec<PathBuf> = (0..6)
        .map(|d| pool.file_for_draw(d).unwrap().to_path_buf())
        .collect();
    let mut first: Vec<_> = draws[..3].to_vec();
    first.sort();
    first.dedup();
    assert_eq!(
        first.len(),
        3,
        "2 tiles and a refresh use all 3 files: {draws:?}"
    );
    assert_eq!(draws[..3], draws[3..], "the order repeats");
    // A refresh makes a tile from the next draw.
    pool.refresh_one(&mut StdRng::seed_from_u64(0)).unwrap();
    assert_eq!(pool.len(), 2);
    std::fs::remove_dir_all(&cache).unwrap();
}

#[test]
fn a_bad_file_in_a_pattern_stops_the_pool_before_any_tile_naming_it() {
    let cache = temp_cache("bad");
    // arad_like, arad_nan, arad_uint16: the second holds a NaN.
    let cfg = config(vec![fixtures().join("arad_*.mat")], 2, 96, &cache);
    let e = ScenePool::new(cfg, lms(), 1, &mut StdRng::seed_from_u64(0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("arad_nan.mat") && e.contains("NaN"), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    let cfg = config(vec![fixtures().join("narrow_bands.mat")], 2, 96, &cache);
    let e = ScenePool::new(cfg, lms(), 1, &mut StdRng::seed_from_u64(0))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("narrow_bands.mat") && e.contains("do not cover"),
        "{e}"
    );
    std::fs::remove_dir_all(&cache).unwrap();
}
