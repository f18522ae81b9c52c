//! Helpers shared by the integration tests that run the `colorvision` binary.
#![allow(dead_code)] // each test file uses some of them

use std::path::Path;
use std::process::{Command, Output};

/// The binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_colorvision");

/// `colorvision ARGS` in `dir`, with no fault injected (`COLORVISION_FAULT` removed) unless
/// `fault` names one, and the scene cache under `dir` (never the user's own).
pub fn command(dir: &Path, args: &[&str], fault: Option<&str>) -> Command {
    let mut c = Command::new(BIN);
    c.args(args)
        .current_dir(dir)
        .env_remove("COLORVISION_FAULT")
        .env("XDG_CACHE_HOME", dir.join(".cache"));
    if let Some(f) = fault {
        c.env("COLORVISION_FAULT", f);
    }
    c
}

/// Runs `colorvision ARGS` in `dir` to the end.
pub fn colorvision(dir: &Path, args: &[&str]) -> Output {
    command(dir, args, None).output().expect("the binary runs")
}

/// What a finished command printed: its stdout, then its stderr.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A fresh empty folder `cv_<test>_<name>_<pid>` in the system's temporary folder.
pub fn scratch_dir(test: &str, name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("cv_{test}_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The run settings a config file gives (`--config PATH`, the `quick` preset where it names
/// none), or the error in words.
pub fn resolve_config_file(path: &Path) -> Result<science::config::RunConfig, String> {
    let options = science::config::Overrides {
        config: Some(path.to_path_buf()),
        ..science::config::Overrides::default()
    };
    science::config::RunConfig::resolve(&options, "quick").map_err(|e| e.to_string())
}
