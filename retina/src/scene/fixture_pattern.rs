//! The pattern every spectral-file fixture holds (`scripts/make_scene_fixtures.py`), for the
//! readers' tests: 5 rows × 7 columns × 31 bands at 400..700 nm, the value at row `y`, column
//! `x`, band `b` being `(y + 16 x + 256 b) / scale` — asymmetric, so a transposed, flipped or
//! band-reversed read fails.

use std::path::{Path, PathBuf};

use super::SpectralImage;

/// A fixture under `retina/tests/fixtures/scenes`.
pub(crate) fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/scenes")
        .join(name)
}

/// The pattern's value at `(y, x, b)` divided by `scale`.
pub(crate) fn pattern(y: usize, x: usize, b: usize, scale: f32) -> f32 {
    (y + 16 * x + 256 * b) as f32 / scale
}

/// `img` is the 5 × 7 × 31 image at 400..700 nm holding `value(y, x, b)`, value by value.
pub(crate) fn assert_pattern(img: &SpectralImage, value: impl Fn(usize, usize, usize) -> f32) {
    assert_eq!((img.h, img.w, img.grid.len()), (5, 7, 31));
    let want_nm: Vec<f64> = (0..31).map(|b| 400.0 + 10.0 * b as f64).collect();
    assert_eq!(img.grid.as_slice(), &want_nm[..]);
    for b in 0..31 {
        for y in 0..5 {
            for x in 0..7 {
                let got = img.data[b * 35 + y * 7 + x];
                assert_eq!(got, value(y, x, b), "(y {y}, x {x}, band {b})");
            }
        }
    }
}
