//! Files a run folder holds: NumPy `.npy` arrays, PNG pictures, JSON and CSV. Every file goes
//! through the workspace's one atomic writer, [`atomic_io::write_atomic`]: the bytes land in a
//! hidden temporary sibling (`.NAME.tmp-PID`, same folder), which is synced and renamed over
//! the target, and the folder is synced. A killed run therefore leaves either the old file or
//! the new one under the real name, never a half-written one; the temporaries it leaves are
//! removed by [`clean_stale_temps`] when a run starts in that folder.

use atomic_io::{process_alive, sync_dir, FileError, TEMP_MARK};
use std::fs;
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

/// Wraps an `std::io::Error` with the path it concerns.
pub fn fs_err(path: &Path) -> impl FnOnce(std::io::Error) -> IoError + '_ {
    move |source| IoError::Fs {
        path: path.to_path_buf(),
        source,
    }
}

impl From<FileError> for IoError {
    fn from(e: FileError) -> Self {
        IoError::Fs {
            path: e.path,
            source: e.source,
        }
    }
}

/// Writes `bytes` to `path` atomically ([`atomic_io::write_atomic`]), creating parent folders.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    Ok(atomic_io::write_atomic(path, bytes)?)
}

/// Copies the file `from` to `to` atomically.
pub fn copy_atomic(from: &Path, to: &Path) -> Result<(), IoError> {
    let bytes = fs::read(from).map_err(fs_err(from))?;
    write_atomic(to, &bytes)
}

/// Runs `save`, which writes any number of files into the folder it is given, and publishes
/// each file into `dir` atomically: `save` writes into a hidden staging folder inside `dir`,
/// then every file is synced and renamed to its place (sub-folders are kept). For writers of
/// other crates that take a folder and write into it directly.
pub fn save_into<E: From<IoError>>(
    dir: &Path,
    save: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let _guard = atomic_io::WriteGuard::enter();
    fs::create_dir_all(dir).map_err(fs_err(dir))?;
    let staging = dir.join(format!(".staging{TEMP_MARK}{}", std::process::id()));
    if staging.exists() {
        fs::remove_dir_all(&staging).map_err(fs_err(&staging))?;
    }
    let result = save(&staging).and_then(|()| Ok(publish(&staging, dir)?));
    let _ = fs::remove_dir_all(&staging);
    result
}

/// Moves every file under `staging` to the same place under `dir`, each synced then renamed
/// (a folder's `config.toml` last).
fn publish(staging: &Path, dir: &Path) -> Result<(), IoError> {
    if !staging.exists() {
        return Ok(());
    }
    let mut entries: Vec<_> = fs::read_dir(staging)
        .map_err(fs_err(staging))?
        .collect::<Result<_, _>>()
        .map_err(fs_err(staging))?;
    // Name order, but a run folder's `config.toml` last: it is what makes a folder a run folder
    // (`crate::run::folder::MARKER_FILE`), so a folder that has it has everything else.
    entries.sort_by_key(|e| (e.file_name() == "config.toml", e.file_name()));
    for entry in entries {
        let from = entry.path();
        let to = dir.join(entry.file_name());
        if from.is_dir() {
            fs::create_dir_all(&to).map_err(fs_err(&to))?;
            publish(&from, &to)?;
        } else {
            fs::File::open(&from)
                .and_then(|f| f.sync_all())
                .map_err(fs_err(&from))?;
            fs::rename(&from, &to).map_err(fs_err(&to))?;
            atomic_io::fault_point("rename");
        }
    }
    Ok(sync_dir(dir)?)
}

/// Whether `name` is a temporary this crate or its dependencies write (`.NAME.tmp-PID`,
/// `.NAME.old-PID`, or the older `NAME.tmpPID`), and the writer's process id.
fn temp_owner(name: &str) -> Option<u32> {
    let digits = |s: &str| s.parse::<u32>().ok();
    if name.starts_with('.') {
        for mark in [TEMP_MARK, ".old-"] {
            if let Some((_, pid)) = name.rsplit_once(mark) {
                return digits(pid);
            }
        }
    }
    let (_, pid) = name.rsplit_once(".tmp")?;
    digits(pid)
}

/// Whether `name` is a temporary this crate or its dependencies write (see `temp_owner`),
/// whoever wrote it.
pub fn is_temporary(name: &str) -> bool {
    temp_owner(name).is_some()
}

/// Removes temporaries left in `dir` (recursively) by writers that were killed, and returns
/// what it removed. Temporaries of a process still running are kept. Checkpoint folders are
/// the cortex's (see `cortex::checkpoint::recover`), which restores a checkpoint moved aside.
pub fn clean_stale_temps(dir: &Path) -> Result<Vec<PathBuf>, IoError> {
    let mut removed = Vec::new();
    if !dir.is_dir() {
        return Ok(removed);
    }
    for entry in fs::read_dir(dir).map_err(fs_err(dir))? {
        let path = entry.map_err(fs_err(dir))?.path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let is_dir = path.is_dir();
        match temp_owner(&name) {
            Some(pid) if !process_alive(pid) && !name.contains(".old-") => {
                let r = if is_dir {
                    fs::remove_dir_all(&path)
                } else {
                    fs::remove_file(&path)
                };
                r.map_err(fs_err(&path))?;
                removed.push(path);
            }
            _ if is_dir && !name.starts_with('.') => {
                removed.extend(clean_stale_temps(&path)?);
            }
            _ => {}
        }
    }
    Ok(removed)
}

/// Serialises `value` as pretty JSON to `path`, atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), IoError> {
    let text = serde_json::to_string_pretty(value).expect("JSON serialisation of plain data");
    write_atomic(path, text.as_bytes())
}

pub use science::summary::read_json;

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
    fn stale_temporaries_of_dead_writers_are_removed_and_live_ones_kept() {
        let dir = std::env::temp_dir().join(format!("cv_stale_{}", std::process::id()));
        let sub = dir.join("pictures");
        fs::create_dir_all(&sub).unwrap();
        // Process id 4294967295 is never running.
        let dead = [
            dir.join(".metrics.csv.tmp-4294967295"),
            sub.join(".ons.png.tmp-4294967295"),
            dir.join("summary.json.tmp4294967295"),
        ];
        for p in &dead {
            fs::write(p, b"half").unwrap();
        }
        fs::create_dir_all(dir.join(".staging.tmp-4294967295")).unwrap();
        let live = dir.join(format!(".x.json.tmp-{}", std::process::id()));
        fs::write(&live, b"in progress").unwrap();
        fs::write(dir.join("keep.json"), b"{}").unwrap();
        let removed = clean_stale_temps(&dir).unwrap();
        assert_eq!(removed.len(), 4, "{removed:?}");
        assert!(dead.iter().all(|p| !p.exists()));
        assert!(live.exists() && dir.join("keep.json").exists());
        fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn save_into_publishes_every_file_and_leaves_no_staging() {
        let dir = std::env::temp_dir().join(format!("cv_save_into_{}", std::process::id()));
        save_into(&dir, |staging| -> Result<(), IoError> {
            fs::create_dir_all(staging.join("sub")).unwrap();
            fs::write(staging.join("a.json"), b"1").unwrap();
            fs::write(staging.join("sub").join("b.svg"), b"2").unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(fs::read(dir.join("a.json")).unwrap(), b"1");
        assert_eq!(fs::read(dir.join("sub").join("b.svg")).unwrap(), b"2");
        let hidden = fs::read_dir(&dir)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with('.')
            })
            .count();
        assert_eq!(hidden, 0);
        fs::remove_dir_all(dir).ok();
    }
}
