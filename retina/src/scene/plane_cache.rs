//! An on-disk cache of prepared scenes: a scene file's class planes, keyed by the file's content
//! and by everything that shaped them, so a second run does not read the cubes again.
//!
//! Layout under the cache folder (default [`default_dir`]):
//! - `sources/<sha256 of the file's canonical path>`: one line `<bytes> <mtime ns> <sha256 of
//!   the content>`. The content hash is taken again only when the size or modification time
//!   changed, so an unchanged file is not read to be recognised.
//! - `planes/<key>.planes`: the planes, `key` the SHA-256 (hex) of the content hash and the
//!   settings ([`PlaneCache::key`]). Format: the 8 bytes `cvplanes`, then `n_planes`, `h`, `w`
//!   as little-endian u32, then `n_planes·h·w` little-endian f32, planar `(n_planes, h, w)`.
//!
//! Files are written atomically (`atomic_io`), so a stopped run leaves no half entry; an entry
//! whose length does not match its header is treated as missing and written again.

use std::io::Read;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::error::{Result, RetinaError};

/// Version of the prepared planes; part of every key, raised when preparation changes.
pub const PREPARATION_VERSION: u32 = 1;

const MAGIC: &[u8; 8] = b"cvplanes";
const HEADER_BYTES: usize = 8 + 3 * 4;

/// The default cache folder: `$XDG_CACHE_HOME/colorvision/scenes`, else
/// `$HOME/.cache/colorvision/scenes` (the XDG base-directory convention).
pub fn default_dir() -> Result<PathBuf> {
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .ok_or_else(|| {
            RetinaError::setting(
                "scenes.cache_dir",
                "neither XDG_CACHE_HOME nor HOME is set: give a folder for prepared scenes",
            )
        })?;
    Ok(base.join("colorvision").join("scenes"))
}

/// Prepared planes read back: `(n_planes, h, w)` planar f32.
#[derive(Debug, Clone, PartialEq)]
pub struct CachedPlanes {
    /// Number of planes.
    pub n_planes: usize,
    /// Rows.
    pub h: usize,
    /// Columns.
    pub w: usize,
    /// `(n_planes, h, w)` values.
    pub data: Vec<f32>,
}

/// The cache folder (module docs).
#[derive(Debug, Clone)]
pub struct PlaneCache {
    dir: PathBuf,
}

impl PlaneCache {
    /// The cache in `dir`, its folders created. Error naming the folder and the setting.
    pub fn open(dir: impl Into<PathBuf>) -> Result<PlaneCache> {
        let dir = dir.into();
        for sub in ["sources", "planes"] {
            std::fs::create_dir_all(dir.join(sub)).map_err(|e| {
                RetinaError::setting(
                    "scenes.cache_dir",
                    format!("{}: cannot create the cache folder ({e})", dir.display()),
                )
            })?;
        }
        Ok(PlaneCache { dir })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// SHA-256 (hex) of the file's content, from the `sources` record when the file's size and
    /// modification time are unchanged, else read and recorded.
    pub fn content_hash(&self, path: &Path) -> Result<String> {
        let meta = std::fs::metadata(path).map_err(|e| RetinaError::io(path, e))?;
        let mtime_ns = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        let stamp = format!("{} {mtime_ns}", meta.len());
        let canonical = std::fs::canonicalize(path).map_err(|e| RetinaError::io(path, e))?;
        let record = self.dir.join("sources").join(hex(&Sha256::digest(
            canonical.as_os_str().as_encoded_bytes(),
        )));
        if let Ok(text) = std::fs::read_to_string(&record) {
            if let Some(hash) = text.trim().strip_prefix(&stamp).map(str::trim) {
                if hash.len() == 64 && hash.bytes().all(|b| b.is_ascii_hexdigit()) {
                    return Ok(hash.to_string());
                }
            }
        }
        let hash = hash_file(path)?;
        atomic_io::write_atomic(&record, format!("{stamp} {hash}\n").as_bytes())?;
        Ok(hash)
    }

    /// SHA-256 (hex) of several files' contents in order (a band stack's band files): the hash
    /// of their names and [`PlaneCache::content_hash`]es.
    pub fn content_hash_all(&self, paths: &[PathBuf]) -> Result<String> {
        let mut h = Sha256::new();
        for p in paths {
            h.update(
                p.file_name()
                    .map(|n| n.as_encoded_bytes())
                    .unwrap_or_default(),
            );
            h.update(self.content_hash(p)?.as_bytes());
        }
        Ok(hex(&h.finalize()))
    }

    /// The key of a file's planes: SHA-256 (hex) of its content hash and `settings` (a
    /// description of everything that shaped the planes), with [`PREPARATION_VERSION`].
    pub fn key(content_hash: &str, settings: &[u8]) -> String {
        let mut h = Sha256::new();
        h.update(PREPARATION_VERSION.to_le_bytes());
        h.update(content_hash.as_bytes());
        h.update(settings);
        hex(&h.finalize())
    }

    /// Path of the planes of `key`.
    pub fn planes_path(&self, key: &str) -> PathBuf {
        self.dir.join("planes").join(format!("{key}.planes"))
    }

    /// The `(n_planes, h, w)` of a complete entry, or `None` when it is missing or incomplete.
    pub fn entry_shape(&self, key: &str) -> Option<(usize, usize, usize)> {
        let path = self.planes_path(key);
        let mut head = [0u8; HEADER_BYTES];
        std::fs::File::open(&path)
            .and_then(|mut f| f.read_exact(&mut head))
            .ok()?;
        let shape = parse_header(&head)?;
        let len = std::fs::metadata(&path).ok()?.len();
        (len == file_len(shape) as u64).then_some(shape)
    }

    /// Write the planes of `key` (atomically).
    pub fn write(&self, key: &str, planes: &CachedPlanes) -> Result<()> {
        let (n, h, w) = (planes.n_planes, planes.h, planes.w);
        assert_eq!(planes.data.len(), n * h * w, "PlaneCache::write: shape");
        let mut bytes = Vec::with_capacity(file_len((n, h, w)));
        bytes.extend_from_slice(MAGIC);
        for v in [n, h, w] {
            bytes.extend_from_slice(&(v as u32).to_le_bytes());
        }
        for v in &planes.data {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        Ok(atomic_io::write_atomic(&self.planes_path(key), &bytes)?)
    }

    /// Read the planes of `key`. Error naming the cache file when it is missing or damaged.
    pub fn read(&self, key: &str) -> Result<CachedPlanes> {
        let path = self.planes_path(key);
        let bytes = std::fs::read(&path).map_err(|e| RetinaError::io(&path, e))?;
        let shape = bytes
            .get(..HEADER_BYTES)
            .and_then(parse_header)
            .filter(|&s| bytes.len() == file_len(s))
            .ok_or_else(|| {
                RetinaError::scene_file(
                    &path,
                    "a damaged prepared-scene cache entry; delete it and run again",
                )
            })?;
        let data = bytes[HEADER_BYTES..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let (n_planes, h, w) = shape;
        Ok(CachedPlanes {
            n_planes,
            h,
            w,
            data,
        })
    }
}

fn parse_header(head: &[u8]) -> Option<(usize, usize, usize)> {
    if head.len() < HEADER_BYTES || &head[..8] != MAGIC {
        return None;
    }
    let u =
        |i: usize| u32::from_le_bytes([head[i], head[i + 1], head[i + 2], head[i + 3]]) as usize;
    Some((u(8), u(12), u(16)))
}

fn file_len((n, h, w): (usize, usize, usize)) -> usize {
    HEADER_BYTES + 4 * n * h * w
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 (hex) of a file's content, read in 1 MiB blocks.
fn hash_file(path: &Path) -> Result<String> {
    let mut f = std::fs::File::open(path).map_err(|e| RetinaError::io(path, e))?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).map_err(|e| RetinaError::io(path, e))?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(hex(&h.finalize()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("plane-cache-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn planes_round_trip_and_damage_is_named() {
        let dir = temp_dir("round-trip");
        let cache = PlaneCache::open(&dir).unwrap();
        let key = PlaneCache::key("abc", b"settings");
        assert_ne!(key, PlaneCache::key("abc", b"other settings"));
        assert_eq!(cache.entry_shape(&key), None);
        let planes = CachedPlanes {
            n_planes: 2,
            h: 3,
            w: 4,
            data: (0..24).map(|i| i as f32 * 0.25 - 1.0).collect(),
        };
        cache.write(&key, &planes).unwrap();
        assert_eq!(cache.entry_shape(&key), Some((2, 3, 4)));
        assert_eq!(cache.read(&key).unwrap(), planes);
        // A cut entry is incomplete, and reading it names the file.
        let path = cache.planes_path(&key);
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 4]).unwrap();
        assert_eq!(cache.entry_shape(&key), None);
        let e = cache.read(&key).unwrap_err().to_string();
        assert!(e.contains(&key) && e.contains("damaged"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_content_hash_is_recorded_and_renewed_when_the_file_changes() {
        let dir = temp_dir("hash");
        let cache = PlaneCache::open(dir.join("cache")).unwrap();
        let file = dir.join("scene.bin");
        std::fs::write(&file, b"one").unwrap();
        let h1 = cache.content_hash(&file).unwrap();
        // SHA-256("one").
        assert_eq!(
            h1,
            "7692c3ad3540bb803c020b3aee66cd8887123234ea0c6e7143c0add73ff431ed"
        );
        // The record answers without reading: a forged record with the same stamp is believed.
        let record = std::fs::read_dir(dir.join("cache/sources"))
            .unwrap()
            .next()
            .unwrap()
            .unwrap()
            .path();
        let text = std::fs::read_to_string(&record).unwrap();
        let forged = text.replace(&h1, &"0".repeat(64));
        std::fs::write(&record, forged).unwrap();
        assert_eq!(cache.content_hash(&file).unwrap(), "0".repeat(64));
        // A changed size renews it.
        std::fs::write(&file, b"three").unwrap();
        let h3 = cache.content_hash(&file).unwrap();
        assert_ne!(h3, "0".repeat(64));
        assert_ne!(h3, h1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
