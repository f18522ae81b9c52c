//! The band-stack reader against the CAVE-style fixture written by Pillow
//! (`scripts/make_scene_fixtures.py`): the cube returned exactly, and errors naming the file.

use super::*;
use crate::scene::fixture_pattern::{assert_pattern, pattern};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/scenes")
}

fn stack() -> PathBuf {
    fixtures().join("cave/pattern_ms/pattern_ms")
}

#[test]
fn a_cave_style_stack_is_read_exactly_in_band_order() {
    let img = read_band_stack(&stack(), &BandStackOptions::default()).unwrap();
    assert_pattern(&img, |y, x, b| pattern(y, x, b, 65535.0));
    // The same scene as the .mat fixture's, up to the integer scale: one layout, two formats.
    let mat = crate::scene::mat_io::read_spectral_mat(
        fixtures().join("arad_uint16.mat"),
        &Default::default(),
    )
    .unwrap();
    assert_eq!(img, mat);
}

#[test]
fn only_numbered_png_folders_are_band_stacks() {
    assert_eq!(band_files(&stack()).unwrap().len(), 31);
    // CAVE's outer folder holds the stack, not bands; a folder of .mat files is no stack.
    assert!(band_files(&fixtures().join("cave/pattern_ms")).is_none());
    assert!(band_files(&fixtures().join("scenes")).is_none());
    // A gap in the numbers, or a second prefix, is no stack.
    let dir = std::env::temp_dir().join(format!("band-stack-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for n in [1, 2, 3, 5] {
        std::fs::copy(
            stack().join(format!("pattern_ms_{n:02}.png")),
            dir.join(format!("s_{n:02}.png")),
        )
        .unwrap();
    }
    assert!(band_files(&dir).is_none(), "a gap at 4");
    std::fs::rename(dir.join("s_05.png"), dir.join("s_04.png")).unwrap();
    assert_eq!(band_files(&dir).unwrap().len(), 4);
    std::fs::copy(stack().join("pattern_ms_05.png"), dir.join("t_05.png")).unwrap();
    assert!(band_files(&dir).is_none(), "two prefixes");
    std::fs::remove_file(dir.join("t_05.png")).unwrap();
    // An unreadable band is named.
    std::fs::write(dir.join("s_04.png"), b"not a png").unwrap();
    let e = read_band_stack(&dir, &BandStackOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("s_04.png"), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_scene_reader_checks_wavelength_cover() {
    let opts = BandStackOptions {
        first_nm: 450.0,
        step_nm: 5.0,
    };
    let e = read_scene_band_stack(&stack(), &opts, &WavelengthGrid::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("pattern_ms") && e.contains("450–600 nm do not cover"),
        "{e}"
    );
}
