//! Spectral scenes stored as one grey PNG per band in a folder, as the CAVE multispectral
//! database (Yasuma et al. 2010) ships them: `balloons_ms/balloons_ms_01.png` …
//! `balloons_ms_31.png`, 512 × 512 px, 16-bit, bands 400–700 nm every 10 nm.
//!
//! A folder is a band stack when it holds at least [`MIN_BANDS`] PNG files, all named
//! `<prefix>_<NN>.png` with one prefix and the numbers 1, 2, … without a gap (any zero
//! padding), and no other scene file. Band `NN` has the wavelength
//! `first_nm + (NN − 1)·step_nm` ([`BandStackOptions`]; CAVE's 400 nm and 10 nm by default).
//! Values: 16-bit samples / 65 535, 8-bit / 255 (linear, as CAVE's are); a colour band image
//! counts as the mean of its R, G, B; alpha is ignored. Every band must have the first one's
//! size.
//!
//! Output: a [`SpectralImage`] `(bands, h, w)` on the bands' wavelengths; [`read_scene_band_stack`]
//! checks every value (finite, ≥ 0) and resamples onto the eye's grid with
//! [`SpectralImage::resample`], as the OpenEXR and `.mat` readers do. Errors name the folder or
//! the band file ([`RetinaError::Png`], [`RetinaError::SceneFile`], [`RetinaError::Io`]).

use std::io::Cursor;
use std::path::{Path, PathBuf};

use colorimetry::WavelengthGrid;
use serde::{Deserialize, Serialize};

use super::exr_io::MAX_SCENE_PIXELS;
use super::SpectralImage;
use crate::error::{Result, RetinaError};

/// Fewest band files a folder must hold to be a band stack.
pub const MIN_BANDS: usize = 3;

/// The wavelengths of a band stack's files (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BandStackOptions {
    /// Wavelength of band 1, nm (CAVE: 400).
    pub first_nm: f64,
    /// Step between bands, nm (CAVE: 10).
    pub step_nm: f64,
}

impl Default for BandStackOptions {
    /// CAVE's bands: 400 nm, then every 10 nm.
    fn default() -> Self {
        BandStackOptions {
            first_nm: 400.0,
            step_nm: 10.0,
        }
    }
}

/// The band files of `dir` in band order, if it is a band stack (module docs).
pub fn band_files(dir: &Path) -> Option<Vec<PathBuf>> {
    let mut bands: Vec<(u32, PathBuf)> = Vec::new();
    let mut prefix: Option<String> = None;
    for item in std::fs::read_dir(dir).ok()? {
        let path = item.ok()?.path();
        let name = path.file_name()?.to_str()?.to_string();
        if name.starts_with('.') || !path.is_file() {
            continue;
        }
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !ext.eq_ignore_ascii_case("png") {
            if super::sources::SceneFormat::of(&path).is_some() {
                return None;
            }
            continue;
        }
        let stem = path.file_stem()?.to_str()?;
        let (head, number) = stem.rsplit_once('_')?;
        if number.is_empty() || !number.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        match &prefix {
            Some(p) if p != head => return None,
            _ => prefix = Some(head.to_string()),
        }
        bands.push((number.parse().ok()?, path));
    }
    bands.sort();
    let consecutive = bands
        .iter()
        .enumerate()
        .all(|(i, (n, _))| *n == i as u32 + 1);
    (bands.len() >= MIN_BANDS && consecutive).then(|| bands.into_iter().map(|b| b.1).collect())
}

/// Read a band stack (module docs) on its own wavelengths.
pub fn read_band_stack(dir: &Path, options: &BandStackOptions) -> Result<SpectralImage> {
    let files = band_files(dir).ok_or_else(|| {
        RetinaError::scene_file(
            dir,
            format!(
                "not a band stack: expected at least {MIN_BANDS} PNG files <name>_1.png, \
                 <name>_2.png, … with no gap"
            ),
        )
    })?;
    if !(options.first_nm.is_finite() && options.step_nm.is_finite() && options.step_nm > 0.0) {
        return Err(RetinaError::setting(
            "scenes.band_stack",
            format!(
                "first_nm {} and step_nm {} must be finite, the step positive",
                options.first_nm, options.step_nm
            ),
        ));
    }
    let mut data = Vec::new();
    let mut size = None;
    for f in &files {
        let (h, w, band) = read_grey_png(f)?;
        match size {
            None => size = Some((h, w)),
            Some(s) if s != (h, w) => {
                return Err(RetinaError::scene_file(
                    f,
                    format!("{w}×{h} px, but band 1 is {}×{} px", s.1, s.0),
                ))
            }
            _ => {}
        }
        data.extend(band);
    }
    let (h, w) = size.expect("a band stack has bands");
    let wavelengths = (0..files.len())
        .map(|i| options.first_nm + i as f64 * options.step_nm)
        .collect();
    let grid = WavelengthGrid::new(wavelengths)
        .map_err(|e| RetinaError::scene_file(dir, format!("band wavelengths: {e}")))?;
    Ok(SpectralImage { grid, h, w, data })
}

/// Read a band stack as a scene's radiance onto `grid`: every value finite and ≥ 0, then
/// resampled with [`SpectralImage::resample`].
pub fn read_scene_band_stack(
    dir: &Path,
    options: &BandStackOptions,
    grid: &WavelengthGrid,
) -> Result<SpectralImage> {
    let img = read_band_stack(dir, options)?;
    img.check_radiance(dir)?;
    img.resample(grid, &dir.display().to_string())
}

/// One band image: `(h, w, values)` (module docs: scaled to [0, 1], colour averaged).
fn read_grey_png(path: &Path) -> Result<(usize, usize, Vec<f32>)> {
    let bytes = std::fs::read(path).map_err(|e| RetinaError::io(path, e))?;
    let err = |m: String| RetinaError::Png {
        path: path.to_path_buf(),
        message: m,
    };
    let mut dec = png::Decoder::new(Cursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(|e| err(e.to_string()))?;
    let (w, h) = (reader.info().width as usize, reader.info().height as usize);
    if w.saturating_mul(h) > MAX_SCENE_PIXELS {
        return Err(err(format!(
            "the header declares {w}×{h} pixels, above the limit of {MAX_SCENE_PIXELS}"
        )));
    }
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| err("image too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| err(e.to_string()))?;
    let (channels, colour) = match info.color_type {
        png::ColorType::Grayscale => (1, 1),
        png::ColorType::GrayscaleAlpha => (2, 1),
        png::ColorType::Rgb => (3, 3),
        png::ColorType::Rgba => (4, 3),
        png::ColorType::Indexed => return Err(err("palette was not expanded".into())),
    };
    let wide = info.bit_depth == png::BitDepth::Sixteen;
    let max = if wide { 65535.0 } else { 255.0 };
    let sample = |row: &[u8], i: usize| -> f32 {
        if wide {
            u16::from_be_bytes([row[2 * i], row[2 * i + 1]]) as f32
        } else {
            row[i] as f32
        }
    };
    let (w, h) = (info.width as usize, info.height as usize);
    let mut out = Vec::with_capacity(h * w);
    for y in 0..h {
        let row = &buf[y * info.line_size..(y + 1) * info.line_size];
        out.extend((0..w).map(|x| {
            let sum: f32 = (0..colour).map(|c| sample(row, x * channels + c)).sum();
            sum / colour as f32 / max
        }));
    }
    Ok((h, w, out))
}

#[cfg(test)]
mod tests;
