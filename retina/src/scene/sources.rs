//! The scene files named by `[retina.scenes] files`: each entry a file, a folder (every scene
//! file in it) or a glob pattern whose last component holds `*` (any run of characters) or `?`
//! (one character), e.g. `data/ARAD_1K_*.mat`.
//!
//! Scene files by extension (case-insensitive): spectral OpenEXR `.exr`; RGB photographs `.png`;
//! hyperspectral cubes `.mat` (MATLAB v7.3), `.h5`, `.hdf5`. Folders and patterns yield the scene
//! files they hold, in name order, and skip other files; a named file of another kind, a folder
//! or pattern that yields none, and a missing file are errors naming the entry. A file named
//! twice is kept once, at its first place.

use std::path::{Path, PathBuf};

use crate::error::{Result, RetinaError};

/// How a scene file is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneFormat {
    /// Spectral OpenEXR ([`super::exr_io`]).
    Exr,
    /// RGB photograph ([`super::rgb`]).
    Png,
    /// MATLAB v7.3 / HDF5 cube ([`super::mat_io`]).
    Mat,
}

impl SceneFormat {
    /// The format of `path` by its extension, if it is a scene file.
    pub fn of(path: &Path) -> Option<SceneFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "exr" => Some(SceneFormat::Exr),
            "png" => Some(SceneFormat::Png),
            "mat" | "h5" | "hdf5" => Some(SceneFormat::Mat),
            _ => None,
        }
    }
}

/// The extensions of scene files, for messages.
const KINDS: &str = ".exr, .png, .mat, .h5 or .hdf5";

/// Every scene file the entries name (module docs).
pub fn expand(entries: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = Vec::new();
    for entry in entries {
        for path in expand_one(entry)? {
            if !out.contains(&path) {
                out.push(path);
            }
        }
    }
    Ok(out)
}

fn bad(entry: &Path, message: impl std::fmt::Display) -> RetinaError {
    RetinaError::setting("scenes.files", format!("`{}`: {message}", entry.display()))
}

fn expand_one(entry: &Path) -> Result<Vec<PathBuf>> {
    let name = entry
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    let wild = |s: &str| s.contains('*') || s.contains('?');
    let parent = entry.parent().unwrap_or(Path::new(""));
    if parent.to_str().is_some_and(wild) {
        return Err(bad(entry, "wildcards are read in the file name only"));
    }
    if wild(name) {
        let dir = if parent.as_os_str().is_empty() {
            Path::new(".")
        } else {
            parent
        };
        let found = scene_files_in(dir, entry, |n| matches(name, n))?;
        if found.is_empty() {
            return Err(bad(entry, format!("matches no {KINDS} file")));
        }
        return Ok(found);
    }
    if entry.is_dir() {
        let found = scene_files_in(entry, entry, |_| true)?;
        if found.is_empty() {
            return Err(bad(entry, format!("the folder holds no {KINDS} file")));
        }
        return Ok(found);
    }
    if !entry.is_file() {
        return Err(bad(entry, "no such file or folder"));
    }
    if SceneFormat::of(entry).is_none() {
        return Err(bad(
            entry,
            format!("expected a {KINDS} file, or a folder of them"),
        ));
    }
    Ok(vec![entry.to_path_buf()])
}

/// Scene files in `dir` whose names pass `keep`, in name order (hidden files skipped).
fn scene_files_in(dir: &Path, entry: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>> {
    let listing = std::fs::read_dir(dir).map_err(|e| bad(entry, e))?;
    let mut found = Vec::new();
    for item in listing {
        let item = item.map_err(|e| bad(entry, e))?;
        let path = item.path();
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        if !name.starts_with('.')
            && keep(name)
            && path.is_file()
            && SceneFormat::of(&path).is_some()
        {
            found.push(if dir == Path::new(".") {
                PathBuf::from(name)
            } else {
                path
            });
        }
    }
    found.sort();
    Ok(found)
}

/// Whether `name` matches `pattern` (`*` any run, `?` one character; everything else literal).
pub fn matches(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let (mut i, mut j) = (0, 0);
    // Last `*` seen in the pattern and the name position it was tried at.
    let mut star: Option<(usize, usize)> = None;
    while j < n.len() {
        if i < p.len() && (p[i] == '?' || p[i] == n[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            // Let the last `*` swallow one more character.
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wildcards_match_as_a_shell_does_in_one_folder() {
        assert!(matches("ARAD_1K_*.mat", "ARAD_1K_0001.mat"));
        assert!(matches("ARAD_1K_*.mat", "ARAD_1K_.mat"));
        assert!(!matches("ARAD_1K_*.mat", "ARAD_1K_0001.mat.bak"));
        assert!(matches("*_0?.png", "balloons_ms_07.png"));
        assert!(!matches("*_0?.png", "balloons_ms_7.png"));
        assert!(matches("a*b*c", "aXbYbZc"));
        assert!(!matches("a*b*c", "aXbYbZ"));
        assert!(matches("*", ""));
        assert!(!matches("?", ""));
    }

    fn fixtures() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/scenes")
    }

    #[test]
    fn folders_and_patterns_yield_scene_files_in_name_order() {
        let dir = fixtures().join("scenes");
        let all = expand(std::slice::from_ref(&dir)).unwrap();
        let names: Vec<_> = all
            .iter()
            .map(|p| p.file_name().unwrap().to_owned())
            .collect();
        assert_eq!(
            names,
            ["ARAD_1K_0001.mat", "ARAD_1K_0002.mat", "ARAD_1K_0003.mat"]
        );
        let some = expand(&[dir.join("ARAD_1K_000[?].mat"), dir.join("*_0002.mat")]);
        assert!(some.is_err(), "`[` is literal: {some:?}");
        let two = expand(&[dir.join("*_000?.mat"), dir.join("ARAD_1K_0002.mat")]).unwrap();
        assert_eq!(two, all, "a file named twice is kept once");
    }

    #[test]
    fn entries_that_name_no_scene_say_which() {
        let dir = fixtures();
        for (entry, want) in [
            (dir.join("nothing_*.mat"), "matches no"),
            (dir.join("missing.mat"), "no such file"),
            (dir.join("*/arad_like.mat"), "file name only"),
            (
                Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"),
                "expected a",
            ),
        ] {
            let e = expand(&[entry]).unwrap_err().to_string();
            assert!(e.contains("scenes.files") && e.contains(want), "{e}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
    }
}
