//! Bad input, tried as a careful tester would: every input below must stop the release binary
//! with a one-line error naming the file (or flag) and the field, exit code 1 (2 for a command
//! line clap rejects), before anything is written — no panic (101), no abort (134), and no
//! silent exit 0. The totals are printed (`cargo test --release --test bad_inputs --
//! --nocapture`).

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_colorvision");

/// One bad input: extra arguments after `train --preset tiny --steps 2 --out out`, an optional
/// `bad.toml` (passed with `--config bad.toml`), and what the error must mention.
struct Case {
    name: &'static str,
    args: &'static [&'static str],
    config: Option<&'static str>,
    expect: &'static [&'static str],
}

const fn case(
    name: &'static str,
    config: Option<&'static str>,
    args: &'static [&'static str],
    expect: &'static [&'static str],
) -> Case {
    Case {
        name,
        args,
        config,
        expect,
    }
}

const CASES: &[Case] = &[
    case(
        "widths 0",
        Some("[cortex.d]\nwidths = [0]"),
        &[],
        &["bad.toml", "cortex.d.widths"],
    ),
    case(
        "widths 8,0",
        Some("[cortex.d]\nwidths = [8, 0]"),
        &[],
        &["bad.toml", "cortex.d.widths"],
    ),
    case(
        "widths huge",
        Some("[cortex.d]\nwidths = [100000000]"),
        &[],
        &["bad.toml", "cortex.d.widths"],
    ),
    case(
        "inverse_guard 0",
        Some("[cortex.w]\ninverse_guard = 0.0"),
        &[],
        &["bad.toml", "cortex.w.inverse_guard"],
    ),
    case(
        "inverse_guard nan",
        Some("[cortex.w]\ninverse_guard = nan"),
        &[],
        &["bad.toml", "cortex.w.inverse_guard"],
    ),
    case(
        "surround 1000",
        Some("[retina.lateral_inhibition]\nsigma_surround_cells = 1000.0"),
        &[],
        &["bad.toml", "retina.lateral_inhibition.sigma_surround_cells"],
    ),
    case(
        "surround 1e30",
        Some("[retina.lateral_inhibition]\nsigma_surround_cells = 1e30"),
        &[],
        &["bad.toml", "retina.lateral_inhibition.sigma_surround_cells"],
    ),
    case(
        "centre -1",
        Some("[retina.lateral_inhibition]\nsigma_centre_cells = -1.0"),
        &[],
        &["bad.toml", "retina.lateral_inhibition.sigma_centre_cells"],
    ),
    case(
        "max_leaves 0",
        Some("[retina.scenes.dead_leaves]\nmax_leaves = 0"),
        &[],
        &["bad.toml", "retina.scenes.dead_leaves.max_leaves"],
    ),
    case(
        "tetra fraction 1.5",
        Some("[retina.scenes.tetra]\nenvironment = \"HueSphere\"\nfraction = 1.5"),
        &[],
        &["bad.toml", "retina.scenes.tetra.fraction"],
    ),
    case(
        "hue sphere of a monochromat",
        Some("[retina.scenes.tetra]\nenvironment = \"HueSphere\"\nfraction = 0.1"),
        &["--cones", "L"],
        &["bad.toml", "retina.scenes.tetra.environment"],
    ),
    case(
        "jitter base 0",
        Some("[retina.layout.Foveated.jitter]\nbase_resolution = 0"),
        &[],
        &["bad.toml", "base_resolution"],
    ),
    case(
        "jitter base 1e9",
        Some("[retina.layout.Foveated.jitter]\nbase_resolution = 1000000000"),
        &[],
        &["bad.toml", "base_resolution"],
    ),
    case(
        "batch 1e8",
        Some("[cortex.train]\nbatch_size = 100000000"),
        &[],
        &["bad.toml", "cortex.train.batch_size"],
    ),
    case(
        "batch 0",
        Some("[cortex.train]\nbatch_size = 0"),
        &[],
        &["bad.toml", "cortex.train.batch_size"],
    ),
    case(
        "learning rate nan",
        Some("[cortex.train]\nlearning_rate = nan"),
        &[],
        &["bad.toml", "cortex.train.learning_rate"],
    ),
    case(
        "learning rate inf",
        Some("[cortex.train]\nlearning_rate = inf"),
        &[],
        &["bad.toml", "cortex.train.learning_rate"],
    ),
    case(
        "adam beta 1.5",
        Some("[cortex.train]\nadam_beta1 = 1.5"),
        &[],
        &["bad.toml", "cortex.train.adam_beta1"],
    ),
    case(
        "percept 0",
        Some("percept_channels = 0\n"),
        &[],
        &["bad.toml", "percept_channels"],
    ),
    case(
        "blur kernel even",
        Some("[cortex.m]\nblur_kernel_px = 8"),
        &[],
        &["bad.toml", "cortex.m.blur_kernel_px"],
    ),
    case(
        "ons size mismatch",
        Some("[cortex]\nons_size_px = 64"),
        &[],
        &["bad.toml", "cortex.ons_size_px"],
    ),
    case(
        "cones per side huge",
        Some("[retina]\ncones_per_side = 100000\n[cortex]\nons_size_px = 100000"),
        &[],
        &["bad.toml", "cones_per_side"],
    ),
    case(
        "max shift 0",
        Some("[retina.eye_motion]\nmax_shift_px = 0"),
        &[],
        &["bad.toml", "retina.eye_motion.max_shift_px"],
    ),
    case(
        "steps twice, disagreeing",
        Some("steps = 9\n[cortex.train]\nsteps = 7"),
        &[],
        &["bad.toml", "cortex.train.steps"],
    ),
    case(
        "oracle false alone",
        Some("oracle_motion = false"),
        &[],
        &["bad.toml", "oracle_motion"],
    ),
    case(
        "oracle true, mode learned",
        Some("oracle_motion = true\n[cortex.m]\nmode = \"learned\""),
        &[],
        &["bad.toml", "oracle_motion"],
    ),
    case(
        "learning rule",
        Some("learning_rule = \"hebb\""),
        &[],
        &[
            "bad.toml",
            "learning_rule",
            "backprop",
            "feedback-alignment",
            "direct-feedback-alignment",
            "forward-forward",
        ],
    ),
    case(
        "learning rule, snake case",
        Some("learning_rule = \"forward_forward\""),
        &[],
        &["bad.toml", "learning_rule", "forward-forward"],
    ),
    case(
        "steps string",
        Some("steps = \"ten\""),
        &[],
        &["bad.toml", "steps"],
    ),
    case(
        "seed negative",
        Some("seed = -1"),
        &[],
        &["bad.toml", "seed"],
    ),
    case(
        "typo",
        Some("[cortex.train]\nlearning_rat = 0.01"),
        &[],
        &["bad.toml", "learning_rat"],
    ),
    case(
        "toml syntax",
        Some("steps = \n"),
        &[],
        &["bad.toml", "line 1"],
    ),
    case(
        "scene file missing",
        Some("[retina.scenes]\nfiles = [\"missing.exr\"]"),
        &[],
        &["missing.exr"],
    ),
    case(
        "cones replace Z",
        None,
        &["--cones", "MS+L_replace_Z"],
        &["--cones", "class Z"],
    ),
    case(
        "cones replace m",
        None,
        &["--cones", "MS+L_replace_m"],
        &["--cones", "class m"],
    ),
    case(
        "cones L:5000",
        None,
        &["--cones", "L:5000"],
        &["--cones", "L:5000"],
    ),
    case(
        "cones L:10",
        None,
        &["--cones", "L:10"],
        &["--cones", "L:10"],
    ),
    case(
        "cones unknown",
        None,
        &["--cones", "XYZ"],
        &["--cones", "XYZ"],
    ),
    case("cones empty", None, &["--cones", ""], &["--cones"]),
    case("steps 0", None, &["--steps", "0"], &["--steps"]),
    case("steps negative", None, &["--steps", "-3"], &["-3"]),
    case("preset", None, &["--preset", "huge"], &["preset", "huge"]),
    case(
        "config missing",
        None,
        &["--config", "nowhere.toml"],
        &["nowhere.toml"],
    ),
    case(
        "resume and force",
        None,
        &["--resume", "--force"],
        &["--force"],
    ),
    case(
        "resume nothing",
        None,
        &["--resume"],
        &["out", "no run to resume"],
    ),
    case(
        "scene EXR NaN",
        Some("[retina.scenes]\nfiles = [\"nan.exr\"]"),
        &[],
        &["nan.exr", "pixel", "NaN"],
    ),
    case(
        "scene EXR negative",
        Some("[retina.scenes]\nfiles = [\"negative.exr\"]"),
        &[],
        &["negative.exr", "pixel", "-1"],
    ),
    case(
        "scene EXR huge header",
        Some("[retina.scenes]\nfiles = [\"huge.exr\"]"),
        &[],
        &["huge.exr", "100000×100000"],
    ),
    case(
        "scene EXR truncated",
        Some("[retina.scenes]\nfiles = [\"truncated.exr\"]"),
        &[],
        &["truncated.exr"],
    ),
    case(
        "scene PNG huge header",
        Some("[retina.scenes]\nfiles = [\"huge.png\"]"),
        &[],
        &["huge.png", "100000×100000"],
    ),
    case(
        "scene PNG garbage",
        Some("[retina.scenes]\nfiles = [\"garbage.png\"]"),
        &[],
        &["garbage.png"],
    ),
];

/// Cases whose `--out` already exists: a plain file, and a folder that is not a run folder.
const OUT_CASES: &[(&str, &[&str])] = &[
    ("out is a file", &["out", "is a file"]),
    (
        "out is a foreign folder",
        &["out", "not a colorvision run folder"],
    ),
    (
        "force on a foreign folder",
        &["out", "not a colorvision run folder"],
    ),
];

/// CRC-32 (IEEE) for patching a PNG chunk.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// Writes the scene files the cases name into `dir`.
fn write_scene_files(dir: &Path) {
    let grid = colorimetry::WavelengthGrid::range(400.0, 700.0, 10.0).unwrap();
    let (h, w) = (8, 8);
    let image = |v: f32| retina::SpectralImage {
        grid: grid.clone(),
        h,
        w,
        data: vec![v; grid.len() * h * w],
    };
    let mut nan = image(0.5);
    nan.data[3 * h * w + 2 * w + 5] = f32::NAN;
    retina::scene::exr_io::write_spectral_exr(&nan, dir.join("nan.exr")).unwrap();
    let mut negative = image(0.5);
    negative.data[7] = -1.0;
    retina::scene::exr_io::write_spectral_exr(&negative, dir.join("negative.exr")).unwrap();
    let good = dir.join("good.exr");
    retina::scene::exr_io::write_spectral_exr(&image(0.5), &good).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(dir.join("truncated.exr"), &bytes[..bytes.len() / 2]).unwrap();
    // The data and display windows (box2i: xMin, yMin, xMax, yMax) declare 100 000².
    let mut huge = bytes.clone();
    for name in [&b"dataWindow\0box2i\0"[..], &b"displayWindow\0box2i\0"[..]] {
        let at = huge.windows(name.len()).position(|w| w == name).unwrap() + name.len() + 4;
        huge[at + 8..at + 12].copy_from_slice(&99_999i32.to_le_bytes());
        huge[at + 12..at + 16].copy_from_slice(&99_999i32.to_le_bytes());
    }
    // … and a chunk count that agrees (ZIP: 16 rows per chunk), so the header is consistent.
    let name = b"chunkCount\0int\0";
    if let Some(at) = huge.windows(name.len()).position(|w| w == name) {
        let at = at + name.len() + 4;
        huge[at..at + 4].copy_from_slice(&6_250i32.to_le_bytes());
    }
    std::fs::write(dir.join("huge.exr"), huge).unwrap();
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, 1, 1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()
            .unwrap()
            .write_image_data(&[1, 2, 3])
            .unwrap();
    }
    // IHDR: length (4) "IHDR" (4) width (4) height (4) … CRC over type and data.
    png_bytes[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    png_bytes[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    let crc = crc32(&png_bytes[12..29]);
    png_bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(dir.join("huge.png"), png_bytes).unwrap();
    std::fs::write(dir.join("garbage.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
}

#[derive(Debug, Default)]
struct Totals {
    tried: usize,
    clear: usize,
    unclear: Vec<String>,
    panics: Vec<String>,
    aborts: Vec<String>,
    silent: Vec<String>,
    wrote: Vec<String>,
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cv_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs one input and files the outcome.
fn try_input(dir: &Path, name: &str, args: &[String], expect: &[&str], totals: &mut Totals) {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env_remove("COLORVISION_FAULT")
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    totals.tried += 1;
    let stderr = String::from_utf8_lossy(&o.stderr).to_string();
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    let label = format!("{name}: {}", stderr.trim());
    use std::os::unix::process::ExitStatusExt;
    match (o.status.code(), o.status.signal()) {
        (Some(101), _) => totals.panics.push(label),
        (Some(134), _) | (None, Some(_)) => totals.aborts.push(label),
        (Some(0), _) => totals.silent.push(label),
        (Some(code), _) => {
            let one_line = lines.len() == 1 || (code == 2 && lines[0].starts_with("error:"));
            let says = expect
                .iter()
                .all(|e| lines.first().is_some_and(|l| l.contains(e)));
            if one_line && says {
                totals.clear += 1;
            } else {
                totals.unclear.push(label);
            }
        }
        (None, None) => totals.aborts.push(label),
    }
}

#[test]
fn every_bad_input_gets_a_one_line_error_naming_file_and_field_and_writes_nothing() {
    let dir = scratch("bad_inputs");
    write_scene_files(&dir);
    let mut totals = Totals::default();
    for c in CASES {
        let mut args: Vec<String> = ["train", "--preset", "tiny", "--steps", "2", "--out", "out"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if let Some(text) = c.config {
            std::fs::write(dir.join("bad.toml"), text).unwrap();
            args.extend(["--config".to_string(), "bad.toml".to_string()]);
        }
        for flag in ["--steps", "--preset"] {
            // The case's own flag replaces the default one.
            if c.args.contains(&flag) {
                let at = args.iter().position(|a| a == flag).unwrap();
                args.drain(at..at + 2);
            }
        }
        args.extend(c.args.iter().map(|s| s.to_string()));
        try_input(&dir, c.name, &args, c.expect, &mut totals);
        if dir.join("out").exists() {
            totals.wrote.push(c.name.to_string());
            std::fs::remove_dir_all(dir.join("out")).unwrap();
        }
    }
    for (name, expect) in OUT_CASES {
        let out = dir.join("out");
        let mut args: Vec<String> = ["train", "--preset", "tiny", "--steps", "2", "--out", "out"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if name.contains("file") {
            std::fs::write(&out, "mine").unwrap();
        } else {
            std::fs::create_dir_all(&out).unwrap();
            std::fs::write(out.join("notes.txt"), "mine").unwrap();
        }
        if name.contains("force") {
            args.push("--force".into());
        }
        try_input(&dir, name, &args, expect, &mut totals);
        let intact = if out.is_file() {
            std::fs::read(&out).unwrap() == b"mine"
        } else {
            std::fs::read_dir(&out).unwrap().count() == 1
        };
        if !intact {
            totals.wrote.push(name.to_string());
        }
        let _ = std::fs::remove_file(&out);
        let _ = std::fs::remove_dir_all(&out);
    }
    // A held-out scene count that does not split into whole batches, halves of them.
    for scenes in ["4", "10"] {
        let args: Vec<String> = ["convergence", "--run", "out", "--held-out-scenes", scenes]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let name = format!("convergence --held-out-scenes {scenes}");
        try_input(
            &dir,
            &name,
            &args,
            &["--held-out-scenes", scenes],
            &mut totals,
        );
        if dir.join("out").exists() {
            totals.wrote.push(name);
        }
    }
    println!(
        "bad inputs: {} tried, {} clear errors, {} unclear, {} panics, {} aborts, {} silent \
         (exit 0), {} wrote files",
        totals.tried,
        totals.clear,
        totals.unclear.len(),
        totals.panics.len(),
        totals.aborts.len(),
        totals.silent.len(),
        totals.wrote.len()
    );
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        totals.clear == totals.tried && totals.wrote.is_empty(),
        "{totals:#?}"
    );
}

/// Settings that were once accepted and then ignored or mislabelled are honoured.
#[test]
fn settings_once_ignored_are_honoured() {
    let dir = scratch("honoured");
    let run = |name: &str, config: &str| {
        std::fs::write(dir.join(format!("{name}.toml")), config).unwrap();
        let o = Command::new(BIN)
            .args(["train", "--config", &format!("{name}.toml"), "--out", name])
            .current_dir(&dir)
            .env_remove("COLORVISION_FAULT")
            .output()
            .unwrap();
        let log = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            o.status.success(),
            "{name}: {log}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let config: toml::Value =
            toml::from_str(&std::fs::read_to_string(dir.join(name).join("config.toml")).unwrap())
                .unwrap();
        let rows = std::fs::read_to_string(dir.join(name).join("metrics.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
        (log, config, rows)
    };
    let (_, config, rows) = run(
        "train_steps",
        "preset = \"tiny\"\n[cortex.train]\nsteps = 7\n",
    );
    assert_eq!(rows, 7, "[cortex.train] steps is the run's steps");
    assert_eq!(config["steps"].as_integer(), Some(7));
    let (log, config, _) = run(
        "learned",
        "preset = \"tiny\"\nsteps = 2\n[cortex.m]\nmode = \"learned\"\n",
    );
    assert!(log.contains("optic nerve signal only"), "{log}");
    assert!(!log.contains("ORACLE"), "{log}");
    assert_eq!(config["oracle_motion"].as_bool(), Some(false));
    std::fs::remove_dir_all(&dir).ok();
}
