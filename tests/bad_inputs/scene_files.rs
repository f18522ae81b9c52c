//! Scene files the bad inputs name: spectral EXRs holding a NaN, a negative value, values near
//! `f32::MAX`, half their bytes, or a header declaring 100 000² pixels; a symbolic link to
//! `/dev/zero`; a PNG declaring as many pixels; a PNG of garbage; MATLAB v7.3 cubes cut short,
//! without a `cube`, holding a NaN, and a MATLAB v5 file.

use std::path::Path;

/// CRC-32 (IEEE) for patching a PNG chunk.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// Writes the scene files the cases name into `dir`.
pub fn write_scene_files(dir: &Path) {
    let grid = colorimetry::WavelengthGrid::range(400.0, 700.0, 10.0).unwrap();
    let (h, w) = (8, 8);
    let image = |v: f32| retina::SpectralImage {
        grid: grid.clone(),
        h,
        w,
        data: vec![v; grid.len() * h * w],
    };
    let mut nan = image(0.5);
    nan.data[3 * h * w + 2 * w + 5] = f32::NAN;
    retina::scene::exr_io::write_spectral_exr(&nan, dir.join("nan.exr")).unwrap();
    let mut negative = image(0.5);
    negative.data[7] = -1.0;
    retina::scene::exr_io::write_spectral_exr(&negative, dir.join("negative.exr")).unwrap();
    // Finite in the file, infinite once summed over wavelengths.
    let mut overflow = image(0.5);
    overflow.data.iter_mut().for_each(|v| *v *= 3e38);
    retina::scene::exr_io::write_spectral_exr(&overflow, dir.join("overflow.exr")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.exr")).unwrap();
    let good = dir.join("good.exr");
    retina::scene::exr_io::write_spectral_exr(&image(0.5), &good).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(dir.join("truncated.exr"), &bytes[..bytes.len() / 2]).unwrap();
    // The data and display windows (box2i: xMin, yMin, xMax, yMax) declare 100 000².
    let mut huge = bytes.clone();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = huge.windows(name.len()).position(|w| w == name).unwrap() + name.len() + 4;
        huge[at + 8..at + 12].copy_from_slice(&99_999i32.to_le_bytes());
        huge[at + 12..at + 16].copy_from_slice(&99_999i32.to_le_bytes());
    }
    // … and a chunk count that agrees (ZIP: 16 rows per chunk), so the header is consistent.
    let name = b"chunkCount\0int\0";
    if let Some(at) = huge.windows(name.len()).position(|w| w == name) {
        let at = at + name.len() + 4;
        huge[at..at + 4].copy_from_slice(&6_250i32.to_le_bytes());
    }
    std::fs::write(dir.join("huge.exr"), huge).unwrap();
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, 1, 1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()
            .unwrap()
            .write_image_data(&[1, 2, 3])
            .unwrap();
    }
    // IHDR: length (4) "IHDR" (4) width (4) height (4) … CRC over type and data.
    png_bytes[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    png_bytes[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    let crc = crc32(&png_bytes[12..29]);
    png_bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(dir.join("huge.png"), png_bytes).unwrap();
    std::fs::write(dir.join("garbage.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    // MATLAB v7.3 cubes written by h5py (retina/tests/fixtures/scenes/README.md).
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("retina/tests/fixtures/scenes");
    for name in [
        "truncated.mat",
        "wrong_dataset.mat",
        "arad_nan.mat",
        "not_hdf5.mat",
    ] {
        std::fs::copy(fixtures.join(name), dir.join(name)).unwrap();
    }
}
