//! The scene files named by `[retina.scenes] files`: each entry a file, a folder or a glob
//! pattern whose last component holds `*` (any run of characters) or `?` (one character), e.g.
//! `data/ARAD_1K_*.mat`.
//!
//! Scenes by extension (case-insensitive): spectral OpenEXR `.exr`; RGB photographs `.png`;
//! hyperspectral cubes `.mat` (MATLAB v7.3), `.h5`, `.hdf5`, and ENVI headers `.hdr` (beside
//! their raw cubes); and folders of one grey PNG per
//! band, CAVE's layout ([`super::band_stack`]). A folder entry that is a band stack is one
//! scene; any other folder yields the scene files it holds and the band stacks beneath it (to
//! [`MAX_DEPTH`] levels, so `data/CAVE` finds CAVE's `balloons_ms/balloons_ms/`). A pattern
//! yields the scene files and band stacks it matches. Files come in name order; other files are
//! skipped. A named file of another kind, a folder or pattern that yields none, and a missing
//! file are errors naming the entry. A scene named twice is kept once, at its first place.

use std::path::{Path, PathBuf};

use super::band_stack::band_files;
use crate::error::{Result, RetinaError};

/// How deep below a folder entry band stacks are looked for.
pub const MAX_DEPTH: usize = 3;

/// How a scene file is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneFormat {
    /// Spectral OpenEXR ([`super::exr_io`]).
    Exr,
    /// RGB photograph ([`super::rgb`]).
    Png,
    /// MATLAB v7.3 / HDF5 cube ([`super::mat_io`]).
    Mat,
    /// A folder of one grey PNG per band ([`super::band_stack`]).
    BandStack,
    /// An ENVI header beside its raw cube ([`super::envi_io`]).
    Envi,
}

impl SceneFormat {
    /// The format of `path`: a band-stack folder, or a scene file by its extension.
    pub fn of(path: &Path) -> Option<SceneFormat> {
        if path.is_dir() {
            return band_files(path).map(|_| SceneFormat::BandStack);
        }
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "exr" => Some(SceneFormat::Exr),
            "png" => Some(SceneFormat::Png),
            "mat" | "h5" | "hdf5" => Some(SceneFormat::Mat),
            "hdr" => Some(SceneFormat::Envi),
            _ => None,
        }
    }
}

/// The extensions of scene files, for messages.
const KINDS: &str = ".exr, .png, .mat, .h5, .hdf5, .hdr (ENVI) or band-stack";

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
        if band_files(entry).is_some() {
            return Ok(vec![entry.to_path_buf()]);
        }
        let mut found = scene_files_in(entry, entry, |_| true)?;
        found.extend(stacks_beneath(entry, MAX_DEPTH));
        if found.is_empty() {
            return Err(bad(entry, format!("the folder holds no {KINDS} file")));
        }
        return Ok(found);
    }
    if !entry.is_file() {
        return Err(bad(entry, not_a_file(entry)));
    }
    if SceneFormat::of(entry).is_none() {
        return Err(bad(
            entry,
            format!("expected a {KINDS} file, or a folder of them"),
        ));
    }
    Ok(vec![entry.to_path_buf()])
}

/// What `path`, which is neither a regular file nor a folder, is: missing, a dangling symbolic
/// link, a device, a pipe or a socket (reading a device such as `/dev/zero` would never end).
fn not_a_file(path: &Path) -> String {
    let link = std::fs::symlink_metadata(path)
        .ok()
        .filter(|m| m.file_type().is_symlink())
        .and_then(|_| std::fs::read_link(path).ok());
    let via = link.as_ref().map_or_else(String::new, |t| {
        format!("a symbolic link to `{}`, which ", t.display())
    });
    let what = match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return if link.is_some() {
                format!("{via}does not exist")
            } else {
                "no such file or folder".into()
            };
        }
        Err(e) => return format!("{via}cannot be read: {e}"),
        Ok(m) => kind_of(&m.file_type()),
    };
    format!("{via}is {what}, not a scene file or folder")
}

/// The kind of a file that is neither regular nor a folder, in words.
fn kind_of(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a named pipe";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    let _ = t;
    "not a regular file"
}

/// Whether the last component of `path` starts with a dot.
fn hidden(path: &Path) -> bool {
    path.file_name()
        .is_some_and(|n| n.as_encoded_bytes().starts_with(b"."))
}

/// Band-stack folders beneath `dir` (not `dir` itself), `depth` levels down, in name order.
fn stacks_beneath(dir: &Path, depth: usize) -> Vec<PathBuf> {
    let Ok(listing) = std::fs::read_dir(dir) else {
        return vec![];
    };
    let mut subs: Vec<PathBuf> = listing
        .filter_map(|i| i.ok().map(|i| i.path()))
        .filter(|p| p.is_dir() && !hidden(p))
        .collect();
    subs.sort();
    let mut out = vec![];
    for sub in subs {
        if band_files(&sub).is_some() {
            out.push(sub);
        } else if depth > 1 {
            out.extend(stacks_beneath(&sub, depth - 1));
        }
    }
    out
}

/// Scene files and band stacks in `dir` whose names pass `keep`, in name order (hidden ones
/// skipped).
fn scene_files_in(dir: &Path, entry: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>> {
    let listing = std::fs::read_dir(dir).map_err(|e| bad(entry, e))?;
    let mut found = Vec::new();
    for item in listing {
        let item = item.map_err(|e| bad(entry, e))?;
        let path = item.path();
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        if !name.starts_with('.') && keep(name) && SceneFormat::of(&path).is_some() {
            if !path.is_file() && !path.is_dir() {
                return Err(bad(&path, not_a_file(&path)));
            }
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

    #[cfg(unix)]
    #[test]
    fn a_device_a_dangling_link_and_a_missing_file_are_each_named_for_what_they_are() {
        let dir = std::env::temp_dir().join(format!("cv_sources_kinds_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("folder")).unwrap();
        let zero = dir.join("zero.exr");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.join("folder/zero.exr")).unwrap();
        let dangling = dir.join("gone.exr");
        std::os::unix::fs::symlink(dir.join("nowhere.exr"), &dangling).unwrap();
        let err = |p: &Path| expand(&[p.to_path_buf()]).unwrap_err().to_string();
        let e = err(&zero);
        assert!(
            e.contains("zero.exr")
                && e.contains("a symbolic link to `/dev/zero`, which is a character device"),
            "{e}"
        );
        let e = err(&dir.join("folder"));
        assert!(
            e.contains("folder/zero.exr") && e.contains("character device"),
            "{e}"
        );
        let e = err(&dangling);
        assert!(e.contains("nowhere.exr`, which does not exist"), "{e}");
        let e = err(&dir.join("missing.exr"));
        assert!(e.contains("missing.exr`: no such file or folder"), "{e}");
        std::fs::remove_dir_all(dir).ok();
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
    fn a_cave_folder_yields_its_nested_band_stack_as_one_scene() {
        let cave = fixtures().join("cave");
        let stack = cave.join("pattern_ms/pattern_ms");
        let one = vec![stack.clone()];
        assert_eq!(expand(std::slice::from_ref(&cave)).unwrap(), one);
        assert_eq!(expand(&one).unwrap(), one);
        assert_eq!(SceneFormat::of(&stack), Some(SceneFormat::BandStack));
        // A pattern matches band stacks too; the fixtures folder holds no stack at depth 1.
        let by_pattern = expand(&[cave.join("pattern_ms/*_ms")]).unwrap();
        assert_eq!(by_pattern, [stack]);
        assert_eq!(SceneFormat::of(&cave), None);
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
