//! `science` is a library a researcher calls from their own code: its normal dependency tree
//! (`cargo tree -p science -e normal`) holds no command-line, progress-bar or signal crate, and
//! no crate of this workspace on it depends on libc itself (libc reaches it only through the
//! numeric crates' threads and random numbers: faer, rand). The command line sits on top of it.

use std::path::Path;
use std::process::Command;

/// `cargo tree -p PACKAGE -e normal --prefix none ARGS`: the package names, one per line.
fn tree(package: &str, args: &[&str]) -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join("../Cargo.toml");
    let out = Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "-p",
            package,
            "-e",
            "normal",
            "--prefix",
            "none",
        ])
        .args(args)
        .arg("--manifest-path")
        .arg(&manifest)
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo tree -p {package} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

/// The workspace's own crates (path dependencies), as `cargo tree` names them.
const WORKSPACE: [&str; 9] = [
    "science",
    "retina",
    "cortex",
    "colorimetry",
    "autodiff",
    "atomic_io",
    "dog_kernel",
    "optic_nerve",
    "colorvision",
];

#[test]
fn the_library_depends_on_no_command_line_terminal_or_signal_crate() {
    let all = tree("science", &[]);
    assert!(all.iter().any(|n| n == "cortex") && all.iter().any(|n| n == "retina"));
    for banned in ["clap", "indicatif", "signal-hook", "colorvision"] {
        assert!(
            !all.iter().any(|n| n == banned),
            "`cargo tree -p science -e normal` holds {banned}: {all:?}"
        );
    }
}

#[test]
fn no_crate_of_this_workspace_on_the_library_s_tree_depends_on_libc_itself() {
    let mut own: Vec<String> = tree("science", &[])
        .into_iter()
        .filter(|n| WORKSPACE.contains(&n.as_str()))
        .collect();
    own.sort();
    own.dedup();
    assert!(
        own.len() >= 5,
        "the workspace crates under science: {own:?}"
    );
    for name in own {
        let direct = tree(&name, &["--depth", "1"]);
        assert!(
            !direct.iter().any(|n| n == "libc"),
            "{name} depends on libc itself: {direct:?}"
        );
    }
}
