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

use std::path::{Path, PathBuf};

use colorimetry::WavelengthGrid;
use serde::{Deserialize, Serialize};

use super::png_io::decode_png;
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
    let png = decode_png(path)?;
    let (colour, max) = (png.colour_channels(), png.full_scale as f32);
    let mut out = Vec::with_capacity(png.h * png.w);
    for y in 0..png.h {
        out.extend((0..png.w).map(|x| {
            let sum: f32 = (0..colour).map(|c| png.colour(y, x, c) as f32).sum();
            sum / colour as f32 / max
        }));
    }
    Ok((png.h, png.w, out))
}

#[cfg(test)]
mod tests;
