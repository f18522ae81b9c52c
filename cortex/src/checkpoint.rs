//! Checkpoints: one directory per step, written atomically, verified on load.
//!
//! Layout of `DIR/step_00000100/`:
//! - `params.safetensors` — every parameter (`w.response`, `c.raw`, `d.*`, `p.*`), opens in
//!   PyTorch/NumPy;
//! - `optim.safetensors` — the optimiser's state per parameter (Adam's `m`, `v`; SGD's
//!   `velocity`) and its step counts;
//! - `rule.safetensors` — the learning rule's state (`autodiff::learn::RuleState`: feedback
//!   matrices, counters; empty for backprop), keyed by parameter names;
//! - `meta.json` — [`CheckpointMeta`]: step, the full config, the trainer's RNG state, the data
//!   source's state and the caller's run state (for exact resume), the last loss, the SHA-256
//!   of both safetensors files (`sha256sum` prints the same) and of `meta.json` itself.
//!
//! Atomicity: the three files are written and synced into a hidden sibling
//! `DIR/.step_….tmp-<pid>`, which is renamed into place (one `rename(2)`), so a killed run
//! never leaves a half-written checkpoint under a real name. Re-saving a step moves the old
//! folder to `DIR/.step_….old-<pid>` first; [`recover`] (run when a run starts in `DIR`) moves
//! it back if the process died between the two renames, and [`newest_first`] counts it as that
//! step's checkpoint meanwhile, so there is no moment at which the step has no checkpoint.
//! [`verify`] checks every checksum; [`latest_valid`] falls back to older checkpoints, saying
//! why it skipped the newer ones.
//!
//! A checkpoint kept for readings may hold `params.safetensors` and `meta.json` only
//! ([`is_params_only`]): readings and continued runs load it ([`verify_params`]), resuming
//! training refuses it ([`verify`]).

use crate::config::CortexConfig;
use crate::optimizer::CortexOptimizer;
use crate::rng::CortexRng;
use crate::CortexError;
use autodiff::learn::RuleState;
use autodiff::ParamStore;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

mod folder;

pub use folder::{latest_checkpoint, latest_valid, newest_first, recover, Valid};

/// Version of the checkpoint layout: 2 adds the checksums and the run state (format 1 still
/// loads, unverified); 3 adds the learning rule's state (format 2 loads without it).
pub const CHECKPOINT_FORMAT: u32 = 3;

/// Files of a checkpoint besides `meta.json`, each with its SHA-256 in the metadata.
pub const CHECKPOINT_FILES: [&str; 3] = [
    "params.safetensors",
    "optim.safetensors",
    "rule.safetensors",
];

/// The files a checkpoint of `format` holds besides `meta.json`.
fn files_of(format: u32) -> &'static [&'static str] {
    match format {
        0..=1 => &[],
        2 => &CHECKPOINT_FILES[..2],
        _ => &CHECKPOINT_FILES,
    }
}

/// `meta.json` of a checkpoint. Field order is fixed and every map is ordered, so the same
/// state always gives the same bytes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointMeta {
    /// [`CHECKPOINT_FORMAT`].
    pub format: u32,
    /// Gradient updates done.
    pub step: u64,
    /// The config the cortex was built from.
    pub config: CortexConfig,
    /// The trainer's RNG state.
    pub rng: CortexRng,
    /// The data source's state ([`crate::DataSource::save_state`]), if it has one.
    pub data_source_state: Option<serde_json::Value>,
    /// Step at which this run continued an earlier cortex on a new data source (boosting /
    /// gene therapy), if it did.
    pub continued_from_step: Option<u64>,
    /// Loss of the last step.
    pub last_loss: Option<f64>,
    /// State of the program driving the trainer (its evaluation stream, measurements so far),
    /// restored by it on resume; the cortex does not read it.
    #[serde(default)]
    pub run_state: Option<serde_json::Value>,
    /// Lower-case hex SHA-256 of each file in [`CHECKPOINT_FILES`].
    #[serde(default)]
    pub files_sha256: BTreeMap<String, String>,
    /// SHA-256 of this metadata serialised (pretty JSON) with this field `null`.
    #[serde(default)]
    pub meta_sha256: Option<String>,
}

impl CheckpointMeta {
    /// The pretty JSON of the metadata with `meta_sha256` left out of the hash, and that hash.
    fn sealed_json(&self, path: &Path) -> Result<(String, String), CortexError> {
        let mut unsealed = self.clone();
        unsealed.meta_sha256 = None;
        let json = |m: &CheckpointMeta| {
            serde_json::to_string_pretty(m).map_err(|e| CortexError::Json {
                path: path.to_path_buf(),
                source: e,
            })
        };
        let hash = sha256_hex(json(&unsealed)?.as_bytes());
        unsealed.meta_sha256 = Some(hash.clone());
        Ok((json(&unsealed)?, hash))
    }
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    lower_hex(&Sha256::digest(bytes))
}

fn lower_hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// [`sha256_hex`] of the file at `path`, read in blocks of 1 MiB (a checkpoint's files are
/// gigabytes at the top of `cortex.p.hidden`'s range).
pub fn sha256_file(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut file = std::fs::File::open(path)?;
    let (mut hasher, mut block) = (Sha256::new(), vec![0u8; 1 << 20]);
    loop {
        match file.read(&mut block) {
            Ok(0) => break,
            Ok(n) => hasher.update(&block[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        }
    }
    Ok(lower_hex(&hasher.finalize()))
}

/// Directory name of the checkpoint of `step`.
pub fn checkpoint_name(step: u64) -> String {
    format!("step_{step:08}")
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> CortexError + '_ {
    move |e| CortexError::io(path, e)
}

fn bad(path: &Path, reason: impl Into<String>) -> CortexError {
    CortexError::Checkpoint {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// Called at named points of [`write_checkpoint`] with the step (fault-injection tests stop
/// the process there, as a crash would).
pub type FaultHook = fn(stage: &'static str, step: u64);

static FAULT_HOOK: OnceLock<FaultHook> = OnceLock::new();

/// Installs a [`FaultHook`] for the rest of the process (the first call wins). The stages are
/// `params-written`, `files-written` (everything in the temporary folder), `old-moved-aside`
/// (re-saving a step, between its two renames) and `renamed`.
pub fn set_fault_hook(hook: FaultHook) {
    let _ = FAULT_HOOK.set(hook);
}

fn fault_point(stage: &'static str, step: u64) {
    if let Some(hook) = FAULT_HOOK.get() {
        hook(stage, step);
    }
}

fn sync(path: &Path) -> Result<(), CortexError> {
    if cfg!(unix) || path.is_file() {
        std::fs::File::open(path)
            .and_then(|f| f.sync_all())
            .map_err(io(path))?;
    }
    Ok(())
}

/// What a checkpoint holds besides its metadata.
pub struct CheckpointState<'a> {
    /// The parameters.
    pub params: &'a ParamStore<f32>,
    /// The optimiser and its state.
    pub optim: &'a CortexOptimizer,
    /// The learning rule's state.
    pub rule: &'a RuleState<f32>,
}

fn write_files(
    tmp: &Path,
    meta: &CheckpointMeta,
    state: &CheckpointState<'_>,
) -> Result<(), CortexError> {
    let (params, optim) = (state.params, state.optim);
    let mut st_meta = BTreeMap::new();
    st_meta.insert("step".to_string(), meta.step.to_string());
    let p = tmp.join(CHECKPOINT_FILES[0]);
    params
        .save_safetensors(&p, &st_meta)
        .map_err(|e| bad(&p, e.to_string()))?;
    fault_point("params-written", meta.step);
    let o = tmp.join(CHECKPOINT_FILES[1]);
    optim
        .save_safetensors(&o, params)
        .map_err(|e| bad(&o, e.to_string()))?;
    let r = tmp.join(CHECKPOINT_FILES[2]);
    state
        .rule
        .save_safetensors(&r)
        .map_err(|e| bad(&r, e.to_string()))?;
    let mut meta = meta.clone();
    for f in files_of(meta.format) {
        let path = tmp.join(f);
        meta.files_sha256
            .insert(f.to_string(), sha256_file(&path).map_err(io(&path))?);
    }
    let m = tmp.join("meta.json");
    let (text, _) = meta.sealed_json(&m)?;
    std::fs::write(&m, text).map_err(io(&m))?;
    sync(&m)?;
    atomic_io::fault_point("write");
    sync(tmp)
}

/// Writes a checkpoint for `meta.step` under `dir` atomically; returns its path.
pub fn write_checkpoint(
    dir: &Path,
    meta: &CheckpointMeta,
    state: &CheckpointState<'_>,
) -> Result<PathBuf, CortexError> {
    let _guard = atomic_io::WriteGuard::enter();
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let name = checkpoint_name(meta.step);
    let fin = dir.join(&name);
    let tmp = atomic_io::temp_sibling(&fin);
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(io(&tmp))?;
    }
    std::fs::create_dir(&tmp).map_err(io(&tmp))?;
    if let Err(e) = write_files(&tmp, meta, state) {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    fault_point("files-written", meta.step);
    if fin.exists() {
        // A rename cannot replace a non-empty folder: move the old one aside first. Until the
        // second rename, `newest_first` and `recover` take the aside copy as this step's.
        let old = dir.join(format!(".{name}.old-{}", std::process::id()));
        if old.exists() {
            std::fs::remove_dir_all(&old).map_err(io(&old))?;
        }
        std::fs::rename(&fin, &old).map_err(io(&fin))?;
        atomic_io::fault_point("rename");
        fault_point("old-moved-aside", meta.step);
        std::fs::rename(&tmp, &fin).map_err(io(&fin))?;
        atomic_io::fault_point("rename");
        let _ = std::fs::remove_dir_all(&old);
    } else {
        std::fs::rename(&tmp, &fin).map_err(io(&fin))?;
        atomic_io::fault_point("rename");
    }
    sync(dir)?;
    fault_point("renamed", meta.step);
    Ok(fin)
}

/// Reads `meta.json` of the checkpoint at `path` and checks its format and its own checksum.
pub fn read_meta(path: &Path) -> Result<CheckpointMeta, CortexError> {
    let m = path.join("meta.json");
    let text = std::fs::read_to_string(&m).map_err(io(&m))?;
    let meta: CheckpointMeta = serde_json::from_str(&text).map_err(|e| CortexError::Json {
        path: m.clone(),
        source: e,
    })?;
    if !(1..=CHECKPOINT_FORMAT).contains(&meta.format) {
        return Err(bad(
            &m,
            format!(
                "format {} is not a supported one (1..={CHECKPOINT_FORMAT})",
                meta.format
            ),
        ));
    }
    if meta.format >= 2 {
        // The hash covers the file's own text with this field `null` (as written), so metadata
        // written before a setting was added still verifies.
        let stored = meta.meta_sha256.clone().unwrap_or_default();
        let unsealed = text.replacen(&format!("\"{stored}\""), "null", 1);
        if stored.is_empty() || sha256_hex(unsealed.as_bytes()) != stored {
            return Err(bad(
                &m,
                "field `meta_sha256` does not match the metadata (the file was changed or damaged)",
            ));
        }
    }
    Ok(meta)
}

/// Whether the checkpoint at `path` holds its parameters only: `params.safetensors` without
/// `optim.safetensors` and `rule.safetensors` (a checkpoint kept for readings, a third of the
/// size; `scripts/record-run.sh` keeps a run's last one so).
pub fn is_params_only(path: &Path) -> bool {
    path.join(CHECKPOINT_FILES[0]).is_file()
        && CHECKPOINT_FILES[1..].iter().all(|f| !path.join(f).exists())
}

/// Reads the metadata of the checkpoint at `path` and checks every checksum and that the step
/// is the folder's: the whole state training resumes from. Format-1 checkpoints carry no
/// checksums; only their metadata is checked. A checkpoint with its parameters only
/// ([`is_params_only`]) is refused, saying so; [`verify_params`] accepts it.
pub fn verify(path: &Path) -> Result<CheckpointMeta, CortexError> {
    if is_params_only(path) {
        return Err(bad(
            path,
            "holds the parameters only (kept for readings, without the optimiser's and the \
             learning rule's state): training cannot resume from it; readings and \
             --continue-from load it",
        ));
    }
    verify_files(path, false)
}

/// [`verify`] for what a reading or a continued run loads (the parameters): a checkpoint
/// with its parameters only verifies too; every file present is still checked.
pub fn verify_params(path: &Path) -> Result<CheckpointMeta, CortexError> {
    verify_files(path, is_params_only(path))
}

fn verify_files(path: &Path, params_only: bool) -> Result<CheckpointMeta, CortexError> {
    let meta = read_meta(path)?;
    let folder = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !folder.contains(&checkpoint_name(meta.step)) {
        return Err(bad(
            &path.join("meta.json"),
            format!("field `step` is {} but the folder is {folder}", meta.step),
        ));
    }
    let files = files_of(meta.format);
    for f in if params_only { &files[..1] } else { files } {
        let file = path.join(f);
        let want = meta.files_sha256.get(*f).ok_or_else(|| {
            bad(
                &path.join("meta.json"),
                format!("no `files_sha256` for {f}"),
            )
        })?;
        let got = sha256_file(&file).map_err(io(&file))?;
        if &got != want {
            return Err(bad(
                &file,
                format!("SHA-256 {got} differs from {want} in meta.json (the file is damaged)"),
            ));
        }
    }
    Ok(meta)
}

/// Loads the parameters of the checkpoint at `path` into `params` (names and shapes must match).
pub fn load_params(path: &Path, params: &mut ParamStore<f32>) -> Result<(), CortexError> {
    let p = path.join(CHECKPOINT_FILES[0]);
    params.load_into(&p).map_err(|e| bad(&p, e.to_string()))?;
    Ok(())
}

/// The learning rule's state of the checkpoint at `path` (`None` for a checkpoint written
/// before the state was saved, format < 3).
pub fn load_rule_state(
    path: &Path,
    meta: &CheckpointMeta,
) -> Result<Option<RuleState<f32>>, CortexError> {
    if meta.format < 3 {
        return Ok(None);
    }
    let r = path.join(CHECKPOINT_FILES[2]);
    RuleState::load_safetensors(&r)
        .map(Some)
        .map_err(|e| bad(&r, e.to_string()))
}

/// Loads the optimiser state of the checkpoint at `path`.
pub fn load_optim(
    path: &Path,
    optim: &mut CortexOptimizer,
    params: &ParamStore<f32>,
) -> Result<(), CortexError> {
    let o = path.join(CHECKPOINT_FILES[1]);
    optim
        .load_safetensors(&o, params)
        .map_err(|e| bad(&o, e.to_string()))
}
