//! EXR round trip and the four failure modes.

use super::*;
use exr::prelude::write_rgb_file;

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("retina-exr-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn test_image(grid: WavelengthGrid, h: usize, w: usize) -> SpectralImage {
    let n = grid.len() * h * w;
    let data = (0..n)
        .map(|i| ((i as f32 * 0.618_034).fract() * 3.0 - 0.5) * 1e-3f32.powi((i % 3) as i32))
        .collect();
    SpectralImage { grid, h, w, data }
}

#[test]
fn round_trip_is_bit_exact() {
    for grid in [
        WavelengthGrid::default(),
        WavelengthGrid::new(vec![380.0, 452.5, 555.25, 700.0, 1000.0]).unwrap(),
    ] {
        let img = test_image(grid, 17, 23);
        let p = tmp("roundtrip.exr");
        write_spectral_exr(&img, &p).unwrap();
        let back = read_spectral_exr(&p).unwrap();
        assert_eq!(back.grid, img.grid);
        assert_eq!((back.h, back.w), (17, 23));
        assert!(back
            .data
            .iter()
            .zip(&img.data)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

#[test]
fn channel_names_carry_wavelengths() {
    assert_eq!(channel_name(550.0), "wl_550nm");
    assert_eq!(channel_name(552.5), "wl_552.5nm");
    assert_eq!(parse_channel_wavelength("wl_550nm"), Some(550.0));
    assert_eq!(parse_channel_wavelength("S0.550,500000nm"), Some(550.5));
    assert_eq!(parse_channel_wavelength("T.700nm"), Some(700.0));
    assert_eq!(parse_channel_wavelength("S1.550,000000nm"), None);
    assert_eq!(parse_channel_wavelength("R"), None);
    assert_eq!(parse_channel_wavelength("wl_xnm"), None);
}

#[test]
fn truncated_and_corrupt_files_are_errors_naming_the_file() {
    let img = test_image(WavelengthGrid::default(), 32, 32);
    let good = tmp("good.exr");
    write_spectral_exr(&img, &good).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let truncated = tmp("truncated.exr");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let not_exr = tmp("not_exr.exr");
    std::fs::write(&not_exr, b"this is not an OpenEXR file at all").unwrap();
    let scrambled = tmp("scrambled.exr");
    let mut s = bytes.clone();
    let mid = s.len() / 2;
    for b in &mut s[mid..mid + 200] {
        *b ^= 0x5a;
    }
    std::fs::write(&scrambled, &s).unwrap();
    for p in [&truncated, &not_exr, &scrambled] {
        let e = read_spectral_exr(p).unwrap_err();
        let msg = e.to_string();
        eprintln!("{msg}");
        assert!(matches!(e, RetinaError::Exr { .. }), "{msg}");
        assert!(msg.contains(&p.display().to_string()), "{msg}");
        assert!(msg.contains("not a readable OpenEXR file"), "{msg}");
    }
    let missing = tmp("does_not_exist.exr");
    let e = read_spectral_exr(&missing).unwrap_err();
    assert!(matches!(e, RetinaError::Io { .. }) && e.to_string().contains("does_not_exist.exr"));
}

#[test]
fn file_without_wavelength_channels_is_an_error_listing_its_channels() {
    let p = tmp("rgb_only.exr");
    write_rgb_file(&p, 8, 8, |x, y| (x as f32, y as f32, 0.5f32)).unwrap();
    let e = read_spectral_exr(&p).unwrap_err();
    let msg = e.to_string();
    eprintln!("{msg}");
    assert!(matches!(e, RetinaError::NoWavelengthChannels { .. }));
    assert!(msg.contains("rgb_only.exr") && msg.contains("no wavelength channels"));
    assert!(msg.contains('R') && msg.contains('G') && msg.contains('B'));
}

#[test]
fn grid_not_covering_the_sensitivities_is_an_error_naming_the_file() {
    let narrow = WavelengthGrid::range(450.0, 650.0, 10.0).unwrap();
    let p = tmp("narrow.exr");
    write_spectral_exr(&test_image(narrow, 4, 4), &p).unwrap();
    let e = read_spectral_exr_on(&p, &WavelengthGrid::default()).unwrap_err();
    let msg = e.to_string();
    eprintln!("{msg}");
    assert!(matches!(e, RetinaError::GridNotCovering { .. }));
    assert!(msg.contains("narrow.exr") && msg.contains("450") && msg.contains("400"));
    // A covering file on another grid is resampled.
    let wide = WavelengthGrid::range(380.0, 720.0, 5.0).unwrap();
    let img = test_image(wide, 3, 3);
    let q = tmp("wide.exr");
    write_spectral_exr(&img, &q).unwrap();
    let on = read_spectral_exr_on(&q, &WavelengthGrid::default()).unwrap();
    assert_eq!(on.grid.len(), 31);
    // 400 nm is sample 4 of the 5-nm file.
    assert_eq!(on.plane(0), img.plane(4));
}
