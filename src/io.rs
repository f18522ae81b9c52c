//! Files a run folder holds: NumPy `.npy` arrays, PNG pictures, JSON and CSV — all written
//! atomically (a temporary file in the same folder, then a rename), so a killed run never leaves
//! a half-written file behind.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

/// An I/O failure, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file system refused.
    #[error("{path}: {source}")]
    Fs {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// PNG encoding failed.
    #[error("{path}: PNG encoding failed: {message}")]
    Png {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

fn fs_err(path: &Path) -> impl FnOnce(std::io::Error) -> IoError + '_ {
    move |source| IoError::Fs {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `bytes` to `path` atomically (temp file + fsync + rename), creating parent folders.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(fs_err(dir))?;
    }
    let tmp = path.with_extension(format!(
        "{}.tmp{}",
        path.extension().and_then(|e| e.to_str()).unwrap_or(""),
        std::process::id()
    ));
    let mut f = fs::File::create(&tmp).map_err(fs_err(&tmp))?;
    f.write_all(bytes).map_err(fs_err(&tmp))?;
    f.sync_all().map_err(fs_err(&tmp))?;
    drop(f);
    fs::rename(&tmp, path).map_err(fs_err(path))
}

/// Serialises `value` as pretty JSON to `path`, atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), IoError> {
    let text = serde_json::to_string_pretty(value).expect("JSON serialisation of plain data");
    write_atomic(path, text.as_bytes())
}

/// Writes a little-endian f32 `.npy` file (NumPy format 1.0, C order) of `shape`.
#[track_caller]
pub fn write_npy_f32(path: &Path, shape: &[usize], data: &[f32]) -> Result<(), IoError> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "write_npy_f32: shape {shape:?} vs {} values",
        data.len()
    );
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape_text = if shape.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape_text}, }}");
    // Magic (6) + version (2) + header length (2) + header + newline must be a multiple of 64.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + 4 * data.len());
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for x in data {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    write_atomic(path, &bytes)
}

/// Writes an 8-bit RGB PNG from `rgb` (row-major, 3 values per pixel, already display-encoded
/// in [0, 1]; values outside are clipped).
#[track_caller]
pub fn write_png_rgb(path: &Path, width: usize, height: usize, rgb: &[f32]) -> Result<(), IoError> {
    assert_eq!(
        rgb.len(),
        width * height * 3,
        "write_png_rgb: {width}×{height} needs {} values, got {}",
        width * height * 3,
        rgb.len()
    );
    let bytes: Vec<u8> = rgb
        .iter()
        .map(|&v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width as u32, height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let png_err = |e: png::EncodingError| IoError::Png {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let mut w = enc.write_header().map_err(png_err)?;
        w.write_image_data(&bytes).map_err(png_err)?;
    }
    write_atomic(path, &out)
}

/// Maps a signed image to RGB for display: 0 is mid-grey, `+max|x|` white, `−max|x|` black.
pub fn signed_to_rgb(values: &[f32]) -> Vec<f32> {
    let m = values.iter().fold(0f32, |m, &v| m.max(v.abs())).max(1e-12);
    values
        .iter()
        .flat_map(|&v| [0.5 + 0.5 * v / m; 3])
        .collect()
}

/// Nearest-neighbour enlargement of an RGB image by an integer `factor` (small mosaics are
/// unreadable at one pixel per cone).
pub fn upscale_rgb(width: usize, height: usize, rgb: &[f32], factor: usize) -> Vec<f32> {
    let (w2, h2) = (width * factor, height * factor);
    let mut out = vec![0.0; w2 * h2 * 3];
    for y in 0..h2 {
        for x in 0..w2 {
            let s = ((y / factor) * width + x / factor) * 3;
            out[(y * w2 + x) * 3..][..3].copy_from_slice(&rgb[s..s + 3]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_data_follows() {
        let dir = std::env::temp_dir().join(format!("cv_npy_{}", std::process::id()));
        let path = dir.join("a.npy");
        write_npy_f32(&path, &[2, 3], &[0., 1., 2., 3., 4., 5.]).unwrap();
        let bytes = fs::read(&path).unwrap();
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + header_len) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        assert!(header.contains("'shape': (2, 3)"), "{header}");
        let data = &bytes[10 + header_len..];
        assert_eq!(data.len(), 24);
        assert_eq!(f32::from_le_bytes(data[20..24].try_into().unwrap()), 5.0);
        fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn atomic_write_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("cv_atomic_{}", std::process::id()));
        write_atomic(&dir.join("x.json"), b"{}").unwrap();
        let names: Vec<_> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("x.json")]);
        fs::remove_dir_all(dir).ok();
    }
}
