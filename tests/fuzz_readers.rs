//! The readers of outside input never panic: the config reader (TOML → RunConfig, validated),
//! the spectral EXR and PNG scene readers, the safetensors reader and checkpoint verification
//! get random bytes and random mutations (flipped bytes, truncations, splices) of valid files,
//! and must return `Ok` or an error. `PROPTEST_CASES` scales the case counts.

use proptest::prelude::*;
use science::config::{Overrides, RunConfig};
use std::path::{Path, PathBuf};

/// Cases per property (the environment's `PROPTEST_CASES` overrides).
const CASES: u32 = 256;

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(CASES),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cv_fuzz_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Bytes overwritten (position, value), a truncation, a slice repeated (start, length).
type Mutation = (Vec<(usize, u8)>, Option<usize>, Option<(usize, usize)>);

/// A mutation of `valid`: some bytes overwritten, then maybe truncated, maybe a slice
/// repeated.
fn mutate(
    valid: &[u8],
    edits: &[(usize, u8)],
    cut: Option<usize>,
    splice: Option<(usize, usize)>,
) -> Vec<u8> {
    let mut b = valid.to_vec();
    for &(at, v) in edits {
        if !b.is_empty() {
            let i = at % b.len();
            b[i] = v;
        }
    }
    if let Some((from, len)) = splice {
        if !b.is_empty() {
            let from = from % b.len();
            let end = (from + len % 64).min(b.len());
            let piece = b[from..end].to_vec();
            b.splice(from..from, piece);
        }
    }
    if let Some(c) = cut {
        b.truncate(c % (b.len() + 1));
    }
    b
}

fn mutation() -> impl Strategy<Value = Mutation> {
    (
        prop::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        prop::option::of(any::<usize>()),
        prop::option::of((any::<usize>(), any::<usize>())),
    )
}

fn resolve(path: &Path) -> Result<RunConfig, String> {
    let options = Overrides {
        config: Some(path.to_path_buf()),
        ..Overrides::default()
    };
    RunConfig::resolve(&options, "tiny").map_err(|e| e.to_string())
}

fn valid_files(dir: &Path) -> (Vec<u8>, Vec<u8>, Vec<u8>, Vec<u8>) {
    let toml = RunConfig::preset("tiny", "LMS")
        .unwrap()
        .to_toml()
        .into_bytes();
    let grid = colorimetry::WavelengthGrid::range(400.0, 700.0, 50.0).unwrap();
    let img = retina::SpectralImage {
        grid: grid.clone(),
        h: 4,
        w: 4,
        data: (0..grid.len() * 16).map(|i| i as f32 * 0.01).collect(),
    };
    let exr = dir.join("valid.exr");
    retina::scene::exr_io::write_spectral_exr(&img, &exr).unwrap();
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, 4, 4);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let data: Vec<u8> = (0..48).map(|i| (i * 5) as u8).collect();
        enc.write_header().unwrap().write_image_data(&data).unwrap();
    }
    let st = dir.join("valid.safetensors");
    let t = autodiff::Tensor::from_vec([2, 3], vec![1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let meta = [("step".to_string(), "7".to_string())]
        .into_iter()
        .collect();
    autodiff::params::write_safetensors(&st, &[("w", &t)], &meta).unwrap();
    (
        toml,
        std::fs::read(exr).unwrap(),
        png_bytes,
        std::fs::read(st).unwrap(),
    )
}

/// Feeds `bytes` to every reader (each through a file, as a user's file arrives).
fn read_all(dir: &Path, bytes: &[u8]) {
    let toml = dir.join("c.toml");
    std::fs::write(&toml, bytes).unwrap();
    let _ = resolve(&toml);
    let exr = dir.join("s.exr");
    std::fs::write(&exr, bytes).unwrap();
    let _ = retina::scene::exr_io::read_spectral_exr(&exr);
    let png_path = dir.join("s.png");
    std::fs::write(&png_path, bytes).unwrap();
    let _ = retina::scene::rgb::RgbImage::read_png(&png_path);
    let st = dir.join("t.safetensors");
    std::fs::write(&st, bytes).unwrap();
    let _ = autodiff::params::read_safetensors::<f32>(&st);
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_bytes_never_panic_any_reader(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
        let dir = scratch(&format!("random_{:?}", std::thread::current().id()));
        read_all(&dir, &bytes);
    }

    #[test]
    fn mutated_configs_never_panic(m in mutation()) {
        let dir = scratch(&format!("toml_{:?}", std::thread::current().id()));
        let (toml, ..) = valid_files(&dir);
        let path = dir.join("m.toml");
        std::fs::write(&path, mutate(&toml, &m.0, m.1, m.2)).unwrap();
        let _ = resolve(&path);
    }

    #[test]
    fn mutated_scene_files_never_panic(m in mutation()) {
        let dir = scratch(&format!("scene_{:?}", std::thread::current().id()));
        let (_, exr, png_bytes, _) = valid_files(&dir);
        let e = dir.join("m.exr");
        std::fs::write(&e, mutate(&exr, &m.0, m.1, m.2)).unwrap();
        let _ = retina::scene::exr_io::read_spectral_exr(&e);
        let p = dir.join("m.png");
        std::fs::write(&p, mutate(&png_bytes, &m.0, m.1, m.2)).unwrap();
        let _ = retina::scene::rgb::RgbImage::read_png(&p);
    }

    #[test]
    fn mutated_safetensors_never_panic(m in mutation()) {
        let dir = scratch(&format!("st_{:?}", std::thread::current().id()));
        let (.., st) = valid_files(&dir);
        let p = dir.join("m.safetensors");
        std::fs::write(&p, mutate(&st, &m.0, m.1, m.2)).unwrap();
        let _ = autodiff::params::read_safetensors::<f32>(&p);
    }
}

/// A valid config value in a field that was never checked does not panic the reader either:
/// typed values of every kind in a few fields.
#[test]
fn typed_values_in_fields_never_panic() {
    let dir = scratch("typed");
    let values = [
        "0",
        "-1",
        "1e308",
        "nan",
        "inf",
        "-inf",
        "\"x\"",
        "[]",
        "{}",
        "true",
        "18446744073709551615",
    ];
    let fields = [
        "steps",
        "seed",
        "[cortex] ons_size_px",
        "[cortex.train] batch_size",
        "[cortex.d] widths",
        "[retina] cones_per_side",
        "[retina] field_px",
        "[retina.eye_motion] max_shift_px",
        "[schedule] eval_batches",
        "[cortex.m] search_radius_px",
    ];
    let mut tried = 0;
    for f in fields {
        for v in values {
            let text = match f.split_once(' ') {
                Some((table, key)) => format!("preset = \"tiny\"\n{table}\n{key} = {v}\n"),
                None => format!("preset = \"tiny\"\n{f} = {v}\n"),
            };
            let path = dir.join("t.toml");
            std::fs::write(&path, text).unwrap();
            let _ = resolve(&path);
            tried += 1;
        }
    }
    assert_eq!(tried, fields.len() * values.len());
    std::fs::remove_dir_all(dir).ok();
}
