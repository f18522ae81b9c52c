//! The ENVI reader against fixtures written by NumPy (`scripts/make_scene_fixtures.py`): the
//! cube returned exactly in both interleaves and byte orders, and errors naming the file.

use super::*;
use crate::scene::fixture_pattern::{assert_pattern, pattern};

fn envi(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/scenes/envi")
        .join(name)
}

/// The `.mat` fixture's cube: `(y + 16 x + 256 b) / 1024`.
fn assert_mat_pattern(img: &SpectralImage) {
    assert_pattern(img, |y, x, b| pattern(y, x, b, 1024.0));
}

#[test]
fn band_interleaved_by_line_big_endian_micrometres_is_read_exactly() {
    assert_mat_pattern(&read_envi(&envi("pattern_bil.hdr")).unwrap());
}

#[test]
fn band_interleaved_by_pixel_scaled_integers_with_decreasing_bands_are_read_exactly() {
    assert_mat_pattern(&read_envi(&envi("pattern_bip.hdr")).unwrap());
}

#[test]
fn headers_with_values_over_several_lines_and_missing_fields() {
    let f = fields("ENVI\nsamples = 7\nwavelength = {\n 400,\n 410}\ndata type=4\n");
    assert_eq!(f["samples"], "7");
    assert_eq!(f["wavelength"], "400, 410");
    assert_eq!(f["data type"], "4");
    let path = Path::new("x.hdr");
    let e = parse_header("ENVI\nsamples = 7\nlines = 5\nbands = 2\n", path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.hdr") && e.contains("wavelength"), "{e}");
    let e = parse_header("samples = 7", path).unwrap_err().to_string();
    assert!(e.contains("not an ENVI header"), "{e}");
    let text = "ENVI\nsamples = 7\nlines = 5\nbands = 1\ndata type = 4\nwavelength = {500}\n\
                interleave = bsq\nwavelength units = Furlongs\n";
    let e = parse_header(text, path).unwrap_err().to_string();
    assert!(e.contains("Furlongs") || e.contains("furlongs"), "{e}");
}

#[test]
fn a_folder_of_envi_cubes_is_prepared_and_its_cube_file_hashed() {
    use crate::scene::pool::ScenePool;
    use crate::scene::projection::SceneProjection;
    use colorimetry::{ConeClass, ConeTemplate};
    use rand::SeedableRng;
    let cache = std::env::temp_dir().join(format!("envi-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let proj = SceneProjection::new(
        &ConeClass::lms(),
        &ConeTemplate::default(),
        &WavelengthGrid::default(),
    )
    .unwrap();
    let mut cfg = crate::RetinaConfig::tiny().scenes;
    cfg.files = vec![envi("pattern_b*.hdr")];
    cfg.cache_dir = Some(cache.clone());
    let mut rng = rand::rngs::StdRng::seed_from_u64(0);
    let pool = ScenePool::new(cfg, proj, 1, &mut rng).unwrap();
    assert_eq!(
        pool.file_for_draw(0).map(|p| p.extension().unwrap()),
        Some("hdr".as_ref())
    );
    assert_eq!(
        cube_file(&envi("pattern_bip.hdr")).unwrap(),
        envi("pattern_bip")
    );
    // Two entries in the sources record per cube: header and cube file.
    assert_eq!(std::fs::read_dir(cache.join("sources")).unwrap().count(), 4);
    std::fs::remove_dir_all(&cache).unwrap();
}

#[test]
fn a_cube_shorter_than_its_header_is_an_error_naming_it() {
    let e = read_scene_envi(&envi("short.hdr"), &WavelengthGrid::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("short.img") && e.contains("2170 bytes") && e.contains("4340"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
}
