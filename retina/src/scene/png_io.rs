//! PNG decoding shared by the RGB photograph reader ([`super::rgb`]) and the band-stack reader
//! ([`super::band_stack`]): 8- and 16-bit grey, grey + alpha, RGB and RGBA (palettes expanded),
//! samples kept as stored (no transfer function) with their full scale (255 or 65 535).
//! A header that declares more than [`MAX_SCENE_PIXELS`] pixels is refused before any pixel
//! buffer is made.

use std::io::Cursor;
use std::path::Path;

use super::exr_io::MAX_SCENE_PIXELS;
use crate::error::{Result, RetinaError};

/// A decoded PNG: `samples[(y·w + x)·channels + c]`, each in `0..=full_scale`.
pub(crate) struct DecodedPng {
    /// Rows.
    pub h: usize,
    /// Columns.
    pub w: usize,
    /// Samples per pixel: 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA.
    pub channels: usize,
    /// Interleaved samples, row-major.
    samples: Vec<u16>,
    /// The largest sample the bit depth holds: 255 or 65 535.
    pub full_scale: u16,
}

impl DecodedPng {
    /// The colour channels of a pixel's layout: 1 for grey (± alpha), 3 for RGB (± alpha).
    pub fn colour_channels(&self) -> usize {
        if self.channels < 3 {
            1
        } else {
            3
        }
    }

    /// Sample `c` of pixel `(y, x)` as stored; a grey image answers every colour channel with
    /// its grey.
    pub fn colour(&self, y: usize, x: usize, c: usize) -> u16 {
        let c = if self.channels < 3 { 0 } else { c };
        self.samples[(y * self.w + x) * self.channels + c]
    }
}

/// Decode the PNG at `path`; errors name the file.
pub(crate) fn decode_png(path: &Path) -> Result<DecodedPng> {
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
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(err("palette was not expanded".into())),
    };
    let wide = info.bit_depth == png::BitDepth::Sixteen;
    let (w, h) = (info.width as usize, info.height as usize);
    let mut samples = Vec::with_capacity(h * w * channels);
    for y in 0..h {
        let row = &buf[y * info.line_size..(y + 1) * info.line_size];
        samples.extend((0..w * channels).map(|i| {
            if wide {
                u16::from_be_bytes([row[2 * i], row[2 * i + 1]])
            } else {
                row[i] as u16
            }
        }));
    }
    Ok(DecodedPng {
        h,
        w,
        channels,
        samples,
        full_scale: if wide { u16::MAX } else { u8::MAX as u16 },
    })
}
