//! The command line: one option vocabulary shared by every subcommand.
//!
//! Doc comments here are also clap's `--help` text, printed verbatim, so placeholders such as
//! `<preset>` stay bare rather than in backticks.
#![allow(rustdoc::invalid_html_tags)]

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand};
use science::config::{ConfigError, Overrides, RunConfig};
use science::observer::ObserverKind;
use std::path::PathBuf;

/// Emergence of colour vision from the optic nerve signal.
///
/// With no subcommand, `colorvision` runs `run`: an LMS eye looks at the built-in natural
/// scenes (the `main` preset), the cortex learns from its optic nerve signal alone, and CMF-SIM measures the colour dimensionality that emerges.
/// Everything lands in a run folder (default `runs/<name>`).
#[derive(Debug, Parser)]
#[command(name = "colorvision", version, about, long_about = None)]
pub struct Cli {
    /// What to do (default: `run`).
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Options for the default `run`.
    #[command(flatten)]
    pub common: CommonOptions,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate an eye, train the cortex on its optic nerve signal, measure the colour
    /// dimensionality with CMF-SIM at checkpoints, and write a run folder with summary.json.
    Run(RunOptions),
    /// Simulate the eye only and write a picture of every stage (scene, mosaic, cone
    /// activations, lateral inhibition, ON/OFF spikes, ONS) and ONS frames under eye motion.
    Simulate(CommonOptions),
    /// Train the cortex (no CMF-SIM): progress bar, metrics.csv, checkpoints, pictures.
    Train(RunOptions),
    /// How far each CMF-SIM test light lies from the colours of the eye's training scenes, in
    /// the eye's own cone-excitation directions: where the test lights leave every colour the
    /// cortex learned from, over the scenes a training of `--steps` draws (writes gamut.json
    /// and gamut.md into --out).
    Gamut(CommonOptions),
    /// Run CMF-SIM on a trained run folder (`--run DIR`) or on an observer whose answer is
    /// known (`--observer identity|cones|oracle|oracle-mosaic|analytic`, with `--cones`), and
    /// write cmf_sim.json and SVG plots (into --out, or DIR/cmf-sim/ for a run folder; the
    /// run's own files are never overwritten).
    CmfSim(CmfSimOptions),
    /// Fit Neural Scope on held-out scenes for a trained run and write percept pictures (into
    /// --out, or DIR/scope/; the run's own pictures/ are never overwritten).
    Scope(RunDirOptions),
    /// Measure every checkpoint of a run folder — the learned invariants against the eye's
    /// truth and, with `--cmf`, the calibrated CMF-SIM — and write convergence.md/json and plots
    /// into DIR/convergence/.
    Convergence(ConvergenceOptions),
    /// Diagnostic: from a trained run's last checkpoint, train on with W held fixed at three
    /// zero-frequency gains (learned, the eye's true one, twice the learned) and compare the
    /// held-out prediction errors: does the loss single out W's DC gain? Writes
    /// DIR/w-dc-gauge/.
    WDcGauge(WDcGaugeOptions),
    /// The colour-matching functions of a trained run (`--run DIR`) with the Stiles & Burch
    /// (1955) primaries against their measured curves, beside the ceiling set by the eye's own
    /// cone fundamentals and the oracle decoder through the same eye (into --out, or
    /// DIR/stiles-burch/).
    StilesBurch(RunDirOptions),
    /// Average the parameters of a run's checkpoints (`--steps a,b,…`: weight averaging of a
    /// plateau) and measure the averaged cortex: CMF-SIM with the run's full budget and the
    /// learned invariants (into --out, or DIR/average/).
    Average(AverageOptions),
    /// How alike two runs' percepts of the same held-out frames are at every checkpoint step
    /// both have (a learning rule's run `--run` against backprop's `--against`): affine R² both
    /// ways and linear CKA, into RUN/percept-alignment/.
    PerceptAlignment(PerceptAlignmentOptions),
    /// Run a named experiment of the paper (see `colorvision experiment list`).
    Experiment(ExperimentOptions),
    /// Continue a stopped `run` or `train` from the newest valid checkpoint of its folder
    /// (the same as repeating its command with `--resume`).
    Resume(ResumeOptions),
    /// Expand a grid of settings (a sweep spec, TOML) into one run folder per run and a Slurm
    /// job-array script (`sbatch DIR/sweep.sbatch`); `--local -j N DIR` runs its tasks here.
    Sweep(crate::sweep::SweepOptions),
    /// One table (gather.csv, gather.md, and index.html linking each run's report) of every run
    /// under DIR from its summary.json: the settings that vary, dimension and margins,
    /// prediction gain, invariants, status.
    Gather(crate::gather::GatherOptions),
}

/// Options of `run` and `train`.
#[derive(Debug, Clone, Default, Args)]
pub struct RunOptions {
    /// The settings and output folder.
    #[command(flatten)]
    pub common: CommonOptions,
    /// Start from the cortex of another run instead of a fresh one: a checkpoint folder, or a
    /// run folder (its newest valid checkpoint). The eye may differ (gene therapy: an MS cortex
    /// on an eye where L replaces some M; boosting: an LMS cortex on an LMSQ eye) but the
    /// cortex's shape must match. Adam starts afresh and the step count continues from the
    /// checkpoint's; `--steps` counts this run's steps.
    #[arg(long, value_name = "PATH")]
    pub continue_from: Option<PathBuf>,
}

/// Options of `resume`.
#[derive(Debug, Clone, Args)]
pub struct ResumeOptions {
    /// The run folder of the stopped run.
    pub dir: PathBuf,
    /// Train on to this many steps in all, past the run's planned end (a finished run too:
    /// its summary.json is kept as summary_step_<old steps>.json). A cosine learning-rate
    /// schedule then spans the new count from the checkpoint on.
    #[arg(long)]
    pub steps: Option<u64>,
}

/// Options every subcommand understands; the default is none given.
#[derive(Debug, Clone, Default, Args)]
pub struct CommonOptions {
    /// Named set of settings: tiny (tests, seconds), quick (64×64 cones, natural scenes, 6 000
    /// steps), main (the default of run and train: the quick eye and cortex, 12 000 steps), long (the quick eye trained 40 000 steps, until
    /// prediction and invariants plateau; the experiments' default), large (128×128 cones,
    /// the quick cortex, 40 000 steps: for a dimension too narrow for the quick eye), sandbox
    /// (official sandbox: no foveation, no lateral inhibition, oracle motion), paper (256×256
    /// cones).
    #[arg(long)]
    pub preset: Option<String>,
    /// Cone types of the retina: a named set (L, M, S, LM, LS, MS, LMS, LMSQ, LMS+pigeonQ, ...)
    /// or custom peaks in nm such as `L:560,S:419`.
    #[arg(long)]
    pub cones: Option<String>,
    /// Seed of every random draw (scenes, mosaic, noise, initialisation).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Number of training steps (gradient updates).
    #[arg(long)]
    pub steps: Option<usize>,
    /// Output folder (default: runs/<command>-<preset>-<cones>-seed<seed>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A TOML file of settings, laid over the preset; command-line options override it. A
    /// whole run `config.toml` that leaves unnamed a setting it reads differently alone (a
    /// record made before the setting existed) is refused, naming the setting.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Scenes from a file, folder or pattern instead of the built-in ones: a hyperspectral cube
    /// (.mat MATLAB v7.3 such as ARAD_1K, .h5, ENVI .hdr), a folder of one PNG per band (CAVE),
    /// a spectral .exr or an RGB .png; the same as setting `[retina.scenes] files = [FILE]`.
    /// Quote a pattern: --scene 'data/ARAD_1K_*.mat'.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Any setting of a --config file, dotted, e.g. `--set cortex.train.learning_rate=3e-4`
    /// (repeatable; laid over the file's settings, validated as they are, and written into the
    /// run's config.toml). With `cmf-sim --run DIR` only `cmf_sim.*` and `observer.*` apply: the
    /// eye and cortex are the run's, and any other key is refused.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Continue the run in the output folder from its newest checkpoint that verifies (run,
    /// train, experiment). The folder's config.toml gives the settings; any option given must
    /// agree with it. The continued run ends as if it had never stopped (same thread count).
    #[arg(long)]
    pub resume: bool,
    /// Empty the output folder first when it holds another run (it must be a run folder).
    #[arg(long, conflicts_with = "resume")]
    pub force: bool,
}

impl CommonOptions {
    /// The settings these options give on top of a preset.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            preset: self.preset.clone(),
            cones: self.cones.clone(),
            seed: self.seed,
            steps: self.steps.map(|s| s as u64),
            config: self.config.clone(),
            scene: self.scene.clone(),
            set: self.set.clone(),
        }
    }

    /// The run's settings: `default_preset` unless one is given, then these options over it.
    pub fn resolve(&self, default_preset: &str) -> Result<RunConfig, ConfigError> {
        RunConfig::resolve(&self.overrides(), default_preset)
    }

    /// What a run may do with a non-empty output folder.
    pub fn folder(&self) -> crate::run::folder::Folder {
        use crate::run::folder::Folder;
        match (self.resume, self.force) {
            (true, _) => Folder::Resume,
            (false, true) => Folder::Replace,
            (false, false) => Folder::New,
        }
    }

    /// Whether any option that changes the settings was given.
    pub fn sets_anything(&self) -> bool {
        self.preset.is_some()
            || self.cones.is_some()
            || self.seed.is_some()
            || self.steps.is_some()
            || self.config.is_some()
            || self.scene.is_some()
            || !self.set.is_empty()
    }
}

/// Options of `cmf-sim`.
#[derive(Debug, Clone, Args)]
pub struct CmfSimOptions {
    /// A run folder written by `run`, `train` or `experiment` (its last checkpoint is tested
    /// with the run's own settings).
    #[arg(long)]
    pub run: Option<PathBuf>,
    /// Which observer: `cortex` (the run's learned cortex; the default with `--run`), or one
    /// whose answer is known, through the eye of `--preset`/`--cones`: `identity` (the percept
    /// is the optic nerve signal: no colour constancy), `cones` (the cone activations: 1),
    /// `oracle` (each kind of cone interpolated across the mosaic: as many dimensions as
    /// independent kinds; cones mixing opsins at random ratios solved by least squares over the
    /// mixtures), `oracle-mosaic` (the oracle without interpolation), `analytic` (the cone
    /// excitations of an ideal eye, no mosaic).
    #[arg(long, value_parser = observer_kind())]
    pub observer: Option<ObserverKind>,
    /// How the patch percept is read: `resolved` (point by point, the default) or
    /// `patch-mean` (kept to show why it is not the default).
    #[arg(long, value_enum)]
    pub readout: Option<ReadoutArg>,
    /// Seed of CMF-SIM's draws (locations, primaries) without changing the eye's seeds.
    #[arg(long)]
    pub location_seed: Option<u64>,
    /// Primary sets tried per K before K is declared failed (the paper used 500).
    #[arg(long)]
    pub sets_per_k: Option<usize>,
    /// Radius of the patch a test light fills, as a fraction of the field side (default 1/8):
    /// eyes of different cone counts compared with patches of the same number of cones.
    #[arg(long)]
    pub patch_radius_fraction: Option<f64>,
    /// Keep every patch's edge at least this many mean cone spacings from the field's edge (a
    /// diagnostic of the lattice's rim; the default placement leaves about 2 on the quick eye).
    #[arg(long)]
    pub edge_clearance_cones: Option<f64>,
    /// With `--run`: test the run's checkpoint of this step (`checkpoints/step_<N>/`) instead
    /// of its newest one.
    #[arg(long)]
    pub checkpoint_step: Option<u64>,
    /// Shared options (`--cones`, `--seed`, `--out`, ...).
    #[command(flatten)]
    pub common: CommonOptions,
}

/// `--observer`: one of [`ObserverKind::ALL`] by its name.
fn observer_kind() -> impl TypedValueParser<Value = ObserverKind> {
    let names = ObserverKind::ALL.map(ObserverKind::name);
    PossibleValuesParser::new(names)
        .map(|name: String| ObserverKind::from_name(&name).expect("a name ObserverKind::ALL lists"))
}

/// `--readout` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReadoutArg {
    /// Point by point in patch-relative coordinates.
    Resolved,
    /// The patch mean.
    PatchMean,
}

/// Options of commands that read a run folder.
#[derive(Debug, Clone, Args)]
pub struct RunDirOptions {
    /// The run folder.
    #[arg(long)]
    pub run: PathBuf,
    /// Measure the run's checkpoint of this step (`checkpoints/step_<N>/`) instead of its
    /// newest one.
    #[arg(long)]
    pub checkpoint_step: Option<u64>,
    /// Shared options.
    #[command(flatten)]
    pub common: CommonOptions,
}

/// Options of `convergence`.
#[derive(Debug, Clone, Args)]
pub struct ConvergenceOptions {
    /// The run folder; repeated (`--run A --run B …`, e.g. one per seed), each run is studied
    /// and `--out` gets their measures side by side.
    #[arg(long, required = true)]
    pub run: Vec<PathBuf>,
    /// With several runs: the folder for the side-by-side plots and `runs.md`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also run CMF-SIM (the run's full budget) at every checkpoint.
    #[arg(long)]
    pub cmf: bool,
    /// With `--cmf`: only at these steps (comma-separated), e.g. `--cmf-steps 4000,16000`.
    #[arg(long, value_delimiter = ',')]
    pub cmf_steps: Vec<u64>,
    /// Only the checkpoints at these steps (comma-separated), e.g. `--steps 24000,40000`;
    /// every checkpoint without it.
    #[arg(long, value_delimiter = ',')]
    pub steps: Vec<u64>,
    /// Held-out scenes behind the hidden and direction R² (a multiple of 4, at least 8), half
    /// fitting and half scoring, a fresh scene tile every batch of 4; the default is converged
    /// (docs/notebook/2026-12-05-hidden-signal-convergence.md). A kept checkpoint measured on
    /// another count or stream is measured again.
    #[arg(long, default_value_t = science::invariants::HELD_OUT_SCENES)]
    pub held_out_scenes: usize,
}

/// Options of `average`.
#[derive(Debug, Clone, Args)]
pub struct AverageOptions {
    /// The trained run folder.
    #[arg(long)]
    pub run: PathBuf,
    /// The checkpoints to average, by step (comma-separated, at least two).
    #[arg(long, value_delimiter = ',', required = true)]
    pub steps: Vec<u64>,
    /// Where to write (default DIR/average/).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Options of `w-dc-gauge`.
#[derive(Debug, Clone, Args)]
pub struct WDcGaugeOptions {
    /// The trained run folder.
    #[arg(long)]
    pub run: PathBuf,
    /// Training steps of each arm.
    #[arg(long, default_value_t = 2000)]
    pub steps: u64,
}

/// Options of `percept-alignment`.
#[derive(Debug, Clone, Args)]
pub struct PerceptAlignmentOptions {
    /// The run whose percept is compared (e.g. a learning rule's).
    #[arg(long)]
    pub run: PathBuf,
    /// The run it is compared against (e.g. backprop's, through the same eye).
    #[arg(long)]
    pub against: PathBuf,
    /// Held-out batches (of the run's batch size) whose first frames are decoded.
    #[arg(long, default_value_t = 4)]
    pub batches: usize,
}

/// Options of `experiment`.
#[derive(Debug, Clone, Args)]
pub struct ExperimentOptions {
    /// The experiment's name, or `list`.
    pub name: String,
    /// Shared options.
    #[command(flatten)]
    pub common: CommonOptions,
}
