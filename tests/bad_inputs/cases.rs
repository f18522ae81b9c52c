//! The bad inputs tried: one line each of what is given and what its error must name.

/// One bad input: extra arguments after `train --preset tiny --steps 2 --out out`, an optional
/// `bad.toml` (passed with `--config bad.toml`), and what the error must mention.
pub struct Case {
    pub name: &'static str,
    pub args: &'static [&'static str],
    pub config: Option<&'static str>,
    pub expect: &'static [&'static str],
}

pub(super) const fn case(
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

pub const CASES: &[Case] = &[
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
        "hue rule for idealised colours",
        Some("[retina.scenes.tetra]\nenvironment = \"Idealised\"\nfraction = 0.1\nhue_rule = \"max_chroma\""),
        &[],
        &["bad.toml", "retina.scenes.tetra.hue_rule"],
    ),
    case(
        "unknown hue rule",
        Some("[retina.scenes.tetra]\nenvironment = \"HueSphere\"\nfraction = 0.1\nhue_rule = \"brightest\""),
        &[],
        &["bad.toml", "hue_rule", "max_chroma"],
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
        "set unknown key",
        None,
        &["--set", "cortex.train.learning_rat=3e-4"],
        &["--set", "learning_rat"],
    ),
    case(
        "set wrong type",
        None,
        &["--set", "cortex.train.batch_size=many"],
        &["--set", "batch_size"],
    ),
    case(
        "set out of range",
        None,
        &["--set", "cortex.train.learning_rate=-1"],
        &["--set cortex.train.learning_rate", "positive"],
    ),
    case(
        "set no value",
        None,
        &["--set", "steps"],
        &["--set", "KEY=VALUE"],
    ),
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
        "scene EXR values near f32::MAX",
        Some("[retina.scenes]\nfiles = [\"overflow.exr\"]"),
        &[],
        &["overflow.exr", "pixel (x", "too large"],
    ),
    case(
        "scene a symlink to /dev/zero",
        Some("[retina.scenes]\nfiles = [\"zero.exr\"]"),
        &[],
        &["zero.exr", "/dev/zero", "character device"],
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
    case(
        "scene MAT truncated",
        None,
        &["--scene", "truncated.mat"],
        &["truncated.mat", "truncated"],
    ),
    case(
        "scene MAT without cube",
        Some("[retina.scenes]\nfiles = [\"wrong_dataset.mat\"]"),
        &[],
        &["wrong_dataset.mat", "no dataset `cube`", "radiance"],
    ),
    case(
        "scene MAT NaN",
        Some("[retina.scenes]\nfiles = [\"arad_*.mat\"]"),
        &[],
        &["arad_nan.mat", "pixel", "NaN"],
    ),
    case(
        "scene MAT v5",
        None,
        &["--scene", "not_hdf5.mat"],
        &["not_hdf5.mat", "MATLAB v5"],
    ),
    case(
        "scene pattern matching nothing",
        None,
        &["--scene", "ARAD_1K_*.mat"],
        &["scenes.files", "ARAD_1K_*.mat", "matches no"],
    ),
];

/// Cases whose `--out` already exists: a plain file, and a folder that is not a run folder.
pub const OUT_CASES: &[(&str, &[&str])] = &[
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
