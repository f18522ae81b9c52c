//! Hyperspectral cubes in the ENVI format of hyperspectral cameras and remote sensing: a text
//! header `NAME.hdr` beside the raw cube (`NAME`, `NAME.img`, `NAME.raw`, `NAME.dat` or
//! `NAME.bsq` / `.bil` / `.bip`, or the header's `data file`).
//!
//! Header fields read (`key = value`, values in braces may span lines, keys case-insensitive):
//! `samples` (columns), `lines` (rows), `bands`, `header offset` (bytes before the cube, default
//! 0), `data type` (1 u8, 2 i16, 3 i32, 4 f32, 5 f64, 12 u16, 13 u32), `interleave` (`bsq`
//! band-sequential, `bil` band-interleaved by line, `bip` by pixel), `byte order` (0 little, 1
//! big endian, default 0), `wavelength` (one per band, required), `wavelength units`
//! (nanometers, the default, or micrometers, scaled by 1000), `reflectance scale factor` (values
//! divided by it when given). Samples are taken as numbers, as they are.
//!
//! Output: a [`SpectralImage`] `(bands, lines, samples)`, row 0 the first line, on the header's
//! wavelengths (in increasing order); [`read_scene_envi`] checks every value (finite, ≥ 0) and
//! resamples onto the eye's grid with [`SpectralImage::resample`], as the other readers do.
//! Errors name the header or the cube file: a missing field, an unknown data type or
//! interleave, a cube shorter than the header declares, no cube file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use colorimetry::WavelengthGrid;

use super::exr_io::MAX_EXR_VALUES;
use super::SpectralImage;
use crate::error::{Result, RetinaError};

/// The fields of an ENVI header this reader uses (module docs).
#[derive(Debug, Clone, PartialEq)]
struct Header {
    samples: usize,
    lines: usize,
    bands: usize,
    offset: usize,
    data_type: u32,
    interleave: String,
    big_endian: bool,
    wavelengths_nm: Vec<f64>,
    scale: f64,
    data_file: Option<String>,
}

/// `key = value` pairs of a header, keys lower-case, braces stripped.
fn fields(text: &str) -> HashMap<String, String> {
    let mut out = HashMap::new();
    let mut rest = text;
    while let Some(eq) = rest.find('=') {
        let key = rest[..eq]
            .lines()
            .last()
            .unwrap_or("")
            .trim()
            .to_ascii_lowercase();
        let after = rest[eq + 1..].trim_start_matches([' ', '\t']);
        let (value, next) = if let Some(body) = after.strip_prefix('{') {
            let end = body.find('}').unwrap_or(body.len());
            (&body[..end], &body[(end + 1).min(body.len())..])
        } else {
            let end = after.find('\n').unwrap_or(after.len());
            (&after[..end], &after[end..])
        };
        out.insert(key, value.split_whitespace().collect::<Vec<_>>().join(" "));
        rest = next;
    }
    out
}

fn parse_header(text: &str, path: &Path) -> Result<Header> {
    if !text.trim_start().starts_with("ENVI") {
        return Err(RetinaError::scene_file(
            path,
            "not an ENVI header (its first word is not ENVI)",
        ));
    }
    let f = fields(text);
    let number = |key: &str, default: Option<f64>| -> Result<f64> {
        match f.get(key) {
            Some(v) => v.trim().parse::<f64>().map_err(|_| {
                RetinaError::scene_file(path, format!("`{key} = {v}` is not a number"))
            }),
            None => default
                .ok_or_else(|| RetinaError::scene_file(path, format!("the header has no `{key}`"))),
        }
    };
    let count = |key: &str| -> Result<usize> {
        let v = number(key, None)?;
        if v >= 1.0 && v.fract() == 0.0 && v <= MAX_EXR_VALUES as f64 {
            Ok(v as usize)
        } else {
            Err(RetinaError::scene_file(
                path,
                format!("`{key} = {v}` is not a size"),
            ))
        }
    };
    let wavelengths = f.get("wavelength").ok_or_else(|| {
        RetinaError::scene_file(
            path,
            "the header has no `wavelength` list (one per band, nm)",
        )
    })?;
    let units = f.get("wavelength units").map(|u| u.to_ascii_lowercase());
    let unit_nm = match units.as_deref() {
        None | Some("nanometers") | Some("nm") | Some("nanometer") => 1.0,
        Some("micrometers") | Some("um") | Some("µm") | Some("micrometer") | Some("microns") => {
            1000.0
        }
        Some(u) => {
            return Err(RetinaError::scene_file(
                path,
                format!("`wavelength units = {u}`: nanometers or micrometers are read"),
            ))
        }
    };
    let wavelengths_nm = wavelengths
        .split(',')
        // Rounded to 10⁻⁶ nm, so 0.41 µm is 410 nm, not 410.000 000 000 000 06.
        .map(|w| {
            w.trim()
                .parse::<f64>()
                .map(|v| (v * unit_nm * 1e6).round() / 1e6)
        })
        .collect::<std::result::Result<Vec<f64>, _>>()
        .map_err(|_| RetinaError::scene_file(path, "a `wavelength` value is not a number"))?;
    let scale = number("reflectance scale factor", Some(1.0))?;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(RetinaError::scene_file(
            path,
            format!("`reflectance scale factor = {scale}` must be positive"),
        ));
    }
    Ok(Header {
        samples: count("samples")?,
        lines: count("lines")?,
        bands: count("bands")?,
        offset: number("header offset", Some(0.0))? as usize,
        data_type: number("data type", None)? as u32,
        interleave: f
            .get("interleave")
            .map_or("bsq".into(), |s| s.trim().to_ascii_lowercase()),
        big_endian: number("byte order", Some(0.0))? == 1.0,
        wavelengths_nm,
        scale,
        data_file: f.get("data file").cloned(),
    })
}

/// The cube file beside a header (module docs).
fn data_file(hdr: &Path, header: &Header) -> Result<PathBuf> {
    if let Some(name) = &header.data_file {
        let p = hdr.with_file_name(name);
        return p.is_file().then_some(p.clone()).ok_or_else(|| {
            RetinaError::scene_file(hdr, format!("its `data file` {} is missing", p.display()))
        });
    }
    let stem = hdr.with_extension("");
    std::iter::once(stem.clone())
        .chain(
            ["img", "raw", "dat", "bsq", "bil", "bip"]
                .iter()
                .map(|e| stem.with_extension(e)),
        )
        .find(|p| p.is_file())
        .ok_or_else(|| {
            RetinaError::scene_file(
                hdr,
                format!(
                    "no cube file beside it ({} with no extension, .img, .raw, .dat, .bsq, .bil \
                     or .bip)",
                    stem.display()
                ),
            )
        })
}

/// The cube file of the header `hdr` (module docs).
pub fn cube_file(hdr: &Path) -> Result<PathBuf> {
    let text = std::fs::read_to_string(hdr).map_err(|e| RetinaError::io(hdr, e))?;
    data_file(hdr, &parse_header(&text, hdr)?)
}

/// Read an ENVI cube (module docs) from its header `hdr`, on the header's wavelengths.
pub fn read_envi(hdr: &Path) -> Result<SpectralImage> {
    let text = std::fs::read_to_string(hdr).map_err(|e| RetinaError::io(hdr, e))?;
    let h = parse_header(&text, hdr)?;
    if h.wavelengths_nm.len() != h.bands {
        return Err(RetinaError::scene_file(
            hdr,
            format!(
                "{} wavelengths for {} bands",
                h.wavelengths_nm.len(),
                h.bands
            ),
        ));
    }
    let size = match h.data_type {
        1 => 1,
        2 | 12 => 2,
        3 | 4 | 13 => 4,
        5 => 8,
        t => {
            return Err(RetinaError::scene_file(
                hdr,
                format!("`data type = {t}`: 1, 2, 3, 4, 5, 12 and 13 are read"),
            ))
        }
    };
    let n = h.samples.saturating_mul(h.lines).saturating_mul(h.bands);
    if n > MAX_EXR_VALUES {
        return Err(RetinaError::scene_file(
            hdr,
            format!("{n} values; at most {MAX_EXR_VALUES}"),
        ));
    }
    let file = data_file(hdr, &h)?;
    let bytes = std::fs::read(&file).map_err(|e| RetinaError::io(&file, e))?;
    let need = h.offset + n * size;
    if bytes.len() < need {
        return Err(RetinaError::scene_file(
            &file,
            format!(
                "{} bytes, but its header {} declares {need}",
                bytes.len(),
                hdr.display()
            ),
        ));
    }
    let values = decode(&bytes[h.offset..need], h.data_type, h.big_endian, h.scale);
    let (w, lines, nb) = (h.samples, h.lines, h.bands);
    // Index of band b, row y, column x in the file's interleave.
    let at: fn(usize, usize, usize, [usize; 3]) -> usize = match h.interleave.as_str() {
        "bsq" => |b, y, x, [w, l, _]| (b * l + y) * w + x,
        "bil" => |b, y, x, [w, _, nb]| (y * nb + b) * w + x,
        "bip" => |b, y, x, [w, _, nb]| (y * w + x) * nb + b,
        other => {
            return Err(RetinaError::scene_file(
                hdr,
                format!("`interleave = {other}`: bsq, bil and bip are read"),
            ))
        }
    };
    let mut data = Vec::with_capacity(n);
    for b in 0..nb {
        for y in 0..lines {
            data.extend((0..w).map(|x| values[at(b, y, x, [w, lines, nb])]));
        }
    }
    let mut img = SpectralImage {
        grid: WavelengthGrid::default(),
        h: lines,
        w,
        data,
    };
    sort_bands(&mut img, h.wavelengths_nm, hdr)?;
    Ok(img)
}

/// Puts the planes in increasing wavelength order on their grid.
fn sort_bands(img: &mut SpectralImage, wavelengths: Vec<f64>, hdr: &Path) -> Result<()> {
    let mut order: Vec<usize> = (0..wavelengths.len()).collect();
    order.sort_by(|&a, &b| wavelengths[a].total_cmp(&wavelengths[b]));
    let hw = img.h * img.w;
    img.data = order
        .iter()
        .flat_map(|&b| img.data[b * hw..(b + 1) * hw].to_vec())
        .collect();
    img.grid = WavelengthGrid::new(order.iter().map(|&b| wavelengths[b]).collect())
        .map_err(|e| RetinaError::scene_file(hdr, format!("wavelengths: {e}")))?;
    Ok(())
}

/// Samples as f32, divided by `scale`.
fn decode(bytes: &[u8], data_type: u32, big: bool, scale: f64) -> Vec<f32> {
    let word = |c: &[u8]| -> [u8; 8] {
        let mut a = [0u8; 8];
        a[..c.len()].copy_from_slice(c);
        if big {
            a[..c.len()].reverse();
        }
        a
    };
    let value = |c: &[u8]| -> f64 {
        let a = word(c);
        match data_type {
            1 => a[0] as f64,
            2 => i16::from_le_bytes([a[0], a[1]]) as f64,
            12 => u16::from_le_bytes([a[0], a[1]]) as f64,
            3 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            13 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            4 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            _ => f64::from_le_bytes(a),
        }
    };
    let size = match data_type {
        1 => 1,
        2 | 12 => 2,
        3 | 4 | 13 => 4,
        _ => 8,
    };
    bytes
        .chunks_exact(size)
        .map(|c| (value(c) / scale) as f32)
        .collect()
}

/// Read an ENVI cube as a scene's radiance onto `grid`: every value finite and ≥ 0, then
/// resampled with [`SpectralImage::resample`].
pub fn read_scene_envi(hdr: &Path, grid: &WavelengthGrid) -> Result<SpectralImage> {
    let img = read_envi(hdr)?;
    img.check_radiance(hdr)?;
    img.resample(grid, &hdr.display().to_string())
}

#[cfg(test)]
mod tests;
