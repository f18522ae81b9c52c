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
