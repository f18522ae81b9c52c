//! Spectral OpenEXR read and write: one f32 channel per wavelength.
//!
//! Writing: one layer named `spectral`, one channel per wavelength named `wl_<λ>nm` (`wl_550nm`,
//! `wl_552.5nm`), 32-bit float, lossless ZIP-16 compression, so a round trip is bit-exact.
//!
//! Reading accepts, in the first valid layer, channels named
//! - `wl_<λ>nm` (ours), or
//! - `<prefix>.<λ>nm` with `,` or `.` as the decimal mark, the spectral-EXR convention of Fichet,
//!   Pacanowski & Wilkie (2021), e.g. `S0.550,000000nm`; Stokes components `S1`–`S3` are skipped.
//!
//! Other channels (R, G, B, A, …) are ignored. Channels are sorted by wavelength. Samples of any
//! EXR type are converted to f32. Decoding is pedantic, so a truncated or corrupt file is an
//! error rather than a partly zero image. Every error names the file: [`RetinaError::Io`] (cannot
//! read), [`RetinaError::Exr`] (not a valid EXR), [`RetinaError::NoWavelengthChannels`], and,
//! from [`read_spectral_exr_on`], [`RetinaError::GridNotCovering`] when the file's wavelengths
//! do not cover the grid of the cone sensitivities.

use std::io::Cursor;
use std::path::Path;

use colorimetry::WavelengthGrid;
use exr::prelude::*;

use super::SpectralImage;
use crate::error::{Result, RetinaError};

/// Channel name for a wavelength (`wl_550nm`, `wl_552.5nm`).
pub fn channel_name(wavelength_nm: f64) -> String {
    if (wavelength_nm - wavelength_nm.round()).abs() < 1e-9 {
        format!("wl_{}nm", wavelength_nm.round() as i64)
    } else {
        format!("wl_{wavelength_nm}nm")
    }
}

/// The wavelength a channel name carries, if any (module docs).
pub fn parse_channel_wavelength(name: &str) -> Option<f64> {
    let lower = name.to_ascii_lowercase();
    let body = lower.strip_suffix("nm")?;
    let parse = |number: &str| -> Option<f64> {
        let v: f64 = number.replace(',', ".").parse().ok()?;
        (v.is_finite() && v > 0.0).then_some(v)
    };
    if let Some(rest) = body.strip_prefix("wl_") {
        return parse(rest);
    }
    // `<prefix>.<λ>`: the wavelength is the longest tail after a '.' that is a number, so
    // `S0.402.5nm` is 402.5 nm (a '.' decimal mark) and `S0.402,5nm` too.
    body.match_indices('.').find_map(|(i, _)| {
        let (prefix, rest) = (&body[..i], &body[i + 1..]);
        let stokes = ["s1", "s2", "s3"].iter().any(|s| prefix.ends_with(s));
        (!prefix.is_empty() && !stokes)
            .then(|| parse(rest))
            .flatten()
    })
}

/// Write `img` to `path` (module docs).
pub fn write_spectral_exr(img: &SpectralImage, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    let hw = img.h * img.w;
    let channels: Vec<AnyChannel<FlatSamples>> = img
        .grid
        .as_slice()
        .iter()
        .enumerate()
        .map(|(l, &wl)| {
            AnyChannel::new(
                channel_name(wl).as_str(),
                FlatSamples::F32(img.data[l * hw..(l + 1) * hw].to_vec()),
            )
        })
        .collect();
    let layer = Layer::new(
        (img.w, img.h),
        LayerAttributes::named("spectral"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let mut bytes = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| RetinaError::Exr {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    Ok(atomic_io::write_atomic(path, &bytes.into_inner())?)
}

/// Read a spectral EXR (module docs), on the file's own wavelengths.
pub fn read_spectral_exr(path: impl AsRef<Path>) -> Result<SpectralImage> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| RetinaError::io(path, e))?;
    check_exr_size(path, &bytes)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| RetinaError::Exr {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let mut found: Vec<(f64, &AnyChannel<FlatSamples>)> = layer
        .channel_data
        .list
        .iter()
        .filter_map(|c| parse_channel_wavelength(&c.name.to_string()).map(|wl| (wl, c)))
        .collect();
    if found.is_empty() {
        let names: Vec<String> = layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        return Err(RetinaError::NoWavelengthChannels {
            path: path.to_path_buf(),
            found: if names.is_empty() {
                "none".into()
            } else {
                names.join(", ")
            },
        });
    }
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    let wavelengths: Vec<f64> = found.iter().map(|f| f.0).collect();
    let grid = WavelengthGrid::new(wavelengths).map_err(|e| RetinaError::Exr {
        path: path.to_path_buf(),
        message: format!("wavelength channels: {e}"),
    })?;
    let mut data = Vec::with_capacity(found.len() * w * h);
    for (_, c) in &found {
        data.extend(c.sample_data.values_as_f32());
    }
    Ok(SpectralImage { grid, h, w, data })
}

/// Read a spectral EXR as a scene's radiance onto `grid`: [`read_spectral_exr_on`], and every
/// value must be finite and ≥ 0 (the error names the file, the first bad pixel and channel).
pub fn read_scene_exr(path: impl AsRef<Path>, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let path = path.as_ref();
    let img = read_spectral_exr(path)?;
    img.check_radiance(path)?;
    img.resample(grid, &path.display().to_string())
}

/// Largest image a scene file may declare, pixels per channel (2²⁶, e.g. 8192²).
pub const MAX_SCENE_PIXELS: usize = 1 << 26;

/// Largest number of values (pixels × channels) a spectral EXR may declare (2²⁸: 1 GiB of f32).
pub const MAX_EXR_VALUES: usize = 1 << 28;

/// Refuses, from the header alone, an EXR whose image would not fit the limits above.
fn check_exr_size(path: &Path, bytes: &[u8]) -> Result<()> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), true).map_err(|e| {
        RetinaError::Exr {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    })?;
    for header in &meta.headers {
        let size = header.layer_size;
        let pixels = size.width().saturating_mul(size.height());
        let values = pixels.saturating_mul(header.channels.list.len());
        if pixels > MAX_SCENE_PIXELS || values > MAX_EXR_VALUES {
            return Err(RetinaError::Exr {
                path: path.to_path_buf(),
                message: format!(
                    "the header declares {}×{} pixels × {} channels, above the limit of \
                     {MAX_SCENE_PIXELS} pixels and {MAX_EXR_VALUES} values",
                    size.width(),
                    size.height(),
                    header.channels.list.len()
                ),
            });
        }
    }
    Ok(())
}

/// Read a spectral EXR and resample it onto `grid` (the grid of the cone sensitivities). Error
/// naming the file if its wavelengths do not cover `grid`.
pub fn read_spectral_exr_on(
    path: impl AsRef<Path>,
    grid: &WavelengthGrid,
) -> Result<SpectralImage> {
    let path = path.as_ref();
    read_spectral_exr(path)?.resample(grid, &path.display().to_string())
}

#[cfg(test)]
mod tests;
