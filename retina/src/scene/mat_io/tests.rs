//! The reader against fixtures written by h5py (`scripts/make_scene_fixtures.py`): cubes
//! returned exactly — values, band order, orientation — and one-line errors naming the file.

use super::*;

use crate::scene::fixture_pattern::{assert_pattern, fixture};

/// The fixtures' pattern: MATLAB `cube(y+1, x+1, b+1) = (y + 16 x + 256 b) / 1024`.
fn pattern(y: usize, x: usize, b: usize) -> f32 {
    crate::scene::fixture_pattern::pattern(y, x, b, 1024.0)
}

#[test]
fn an_arad_like_cube_is_read_exactly_in_matlab_orientation() {
    let img = read_spectral_mat(fixture("arad_like.mat"), &MatOptions::default()).unwrap();
    assert_pattern(&img, pattern);
    // Row 0 is MATLAB's first row: the top-left pixel of band 1 is 0 and moving right adds
    // 16/1024 per column, down 1/1024 per row (a transposed read would swap these).
    assert_eq!(img.data[1], 16.0 / 1024.0);
    assert_eq!(img.data[7], 1.0 / 1024.0);
}

#[test]
fn sixteen_bit_cubes_are_scaled_and_column_bands_read() {
    let img = read_spectral_mat(fixture("arad_uint16.mat"), &MatOptions::default()).unwrap();
    assert_pattern(&img, |y, x, b| (y + 16 * x + 256 * b) as f32 / 65535.0);
}

#[test]
fn band_first_cubes_with_decreasing_wavelengths_come_out_band_last_and_increasing() {
    let img = read_spectral_mat(fixture("band_first.mat"), &MatOptions::default()).unwrap();
    assert_pattern(&img, pattern);
}

#[test]
fn plain_row_major_hdf5_is_read_in_its_own_order() {
    let opts = MatOptions {
        bands: "wavelengths".into(),
        ..MatOptions::default()
    };
    let img = read_spectral_mat(fixture("row_major.h5"), &opts).unwrap();
    assert_pattern(&img, pattern);
}

#[test]
fn wavelengths_from_the_config_replace_the_files() {
    let opts = MatOptions {
        bands_nm: Some((0..31).map(|b| 405.0 + 10.0 * b as f64).collect()),
        ..MatOptions::default()
    };
    let img = read_spectral_mat(fixture("arad_like.mat"), &opts).unwrap();
    assert_eq!(img.grid.as_slice()[0], 405.0);
    assert_eq!(img.data[35], pattern(0, 0, 1));
    // 30 wavelengths fit no dimension of a 31-band cube.
    let opts = MatOptions {
        bands_nm: Some((0..30).map(|b| 400.0 + 10.0 * b as f64).collect()),
        ..MatOptions::default()
    };
    let e = read_spectral_mat(fixture("arad_like.mat"), &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("[5, 7, 31]") && e.contains("30 bands"), "{e}");
}

#[test]
fn the_scene_reader_resamples_with_the_exr_readers_code() {
    let grid = WavelengthGrid::range(400.0, 700.0, 5.0).unwrap();
    let img = read_scene_mat(fixture("arad_like.mat"), &MatOptions::default(), &grid).unwrap();
    let own = read_spectral_mat(fixture("arad_like.mat"), &MatOptions::default()).unwrap();
    assert_eq!(img, own.resample(&grid, "").unwrap());
    // 405 nm lies halfway between the 400 and 410 nm bands.
    let mid = (pattern(2, 3, 0) + pattern(2, 3, 1)) / 2.0;
    assert!((img.data[35 + 2 * 7 + 3] - mid).abs() < 1e-7);
}

/// The error of reading `name` onto the default grid: one line naming the file.
fn scene_error(name: &str) -> String {
    let e = read_scene_mat(
        fixture(name),
        &MatOptions::default(),
        &WavelengthGrid::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains(name), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    e
}

#[test]
fn bad_files_give_one_line_errors_saying_what_is_wrong() {
    let e = scene_error("truncated.mat");
    assert!(e.contains("truncated: 5071 bytes of the 7607"), "{e}");
    let e = scene_error("not_hdf5.mat");
    assert!(e.contains("MATLAB v5") && e.contains("-v7.3"), "{e}");
    let e = scene_error("wrong_dataset.mat");
    assert!(
        e.contains("no dataset `cube`") && e.contains("radiance") && e.contains("cube = "),
        "{e}"
    );
    let e = scene_error("arad_nan.mat");
    assert!(e.contains("(x 3, y 2) at 440 nm is NaN"), "{e}");
    let e = scene_error("narrow_bands.mat");
    assert!(e.contains("450–650 nm do not cover"), "{e}");
    let e = scene_error("no_such_file.mat");
    assert!(e.contains("No such file"), "{e}");
    let opts = MatOptions {
        bands: "missing".into(),
        ..MatOptions::default()
    };
    let e = read_spectral_mat(fixture("arad_like.mat"), &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no dataset `missing`") && e.contains("bands_nm"),
        "{e}"
    );
}

#[test]
fn the_layout_rule_prefers_bands_last_in_the_arrays_own_order() {
    // MATLAB 482 × 512 × 31 is HDF5 (31, 512, 482).
    let a = CubeAxes::find([31, 512, 482], 31, true).unwrap();
    assert_eq!((a.band, a.row, a.col), (0, 2, 1));
    // A 31 × 31 × 31 cube: bands last in the array's own order.
    let a = CubeAxes::find([31, 31, 31], 31, true).unwrap();
    assert_eq!(a.band, 0);
    let a = CubeAxes::find([31, 31, 31], 31, false).unwrap();
    assert_eq!(a.band, 2);
    // Bands in the middle are not guessed.
    assert_eq!(CubeAxes::find([482, 31, 512], 31, true), None);
}

#[test]
fn corrupt_bytes_anywhere_give_an_error_or_a_cube_never_a_panic() {
    let whole = std::fs::read(fixture("arad_like.mat")).unwrap();
    let path = std::env::temp_dir().join(format!("corrupt-{}.mat", std::process::id()));
    let mut errors = 0;
    for start in (512..whole.len()).step_by(97) {
        let mut bytes = whole.clone();
        let end = (start + 24).min(bytes.len());
        bytes[start..end].iter_mut().for_each(|b| *b ^= 0xA5);
        std::fs::write(&path, &bytes).unwrap();
        let r = std::panic::catch_unwind(|| {
            read_scene_mat(&path, &MatOptions::default(), &WavelengthGrid::default())
        });
        match r.unwrap_or_else(|_| panic!("a panic with bytes {start}..{end} corrupted")) {
            Ok(img) => assert_eq!((img.h, img.w), (5, 7)),
            Err(e) => {
                errors += 1;
                assert_eq!(e.to_string().lines().count(), 1, "{e}");
            }
        }
    }
    std::fs::remove_file(&path).unwrap();
    assert!(errors > 10, "only {errors} corruptions detected");
}
