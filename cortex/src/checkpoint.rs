//! Checkpoints: one directory per step, written atomically.
//!
//! Layout of `DIR/step_00000100/`:
//! - `params.safetensors` — every parameter (`w.response`, `c.raw`, `d.*`, `p.*`), opens in
//!   PyTorch/NumPy;
//! - `optim.safetensors` — Adam's `m`, `v` per parameter and its step counts;
//! - `meta.json` — [`CheckpointMeta`]: step, the full config, the trainer's RNG state, the data
//!   source's state (for exact resume), and the last loss.
//!
//! Atomicity: the three files are written into a hidden sibling `DIR/.step_….tmp-<pid>` and the
//! directory is renamed into place (one `rename(2)`), so a killed run never leaves a
//! half-written checkpoint under a real name. [`latest_checkpoint`] ignores hidden directories.

use crate::config::CortexConfig;
use crate::rng::CortexRng;
use crate::CortexError;
use autodiff::optim::{Adam, Optimizer};
use autodiff::ParamStore;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Version of the checkpoint layout.
pub const CHECKPOINT_FORMAT: u32 = 1;

/// `meta.json` of a checkpoint.
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
}

/// Directory name of the checkpoint of `step`.
pub fn checkpoint_name(step: u64) -> String {
    format!("step_{step:08}")
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> CortexError + '_ {
    move |e| CortexError::io(path, e)
}

/// Writes a checkpoint for `meta.step` under `dir` atomically; returns its path.
pub fn write_checkpoint(
    dir: &Path,
    meta: &CheckpointMeta,
    params: &ParamStore<f32>,
    optim: &Optimizer<f32, Adam>,
) -> Result<PathBuf, CortexError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let name = checkpoint_name(meta.step);
    let fin = dir.join(&name);
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(io(&tmp))?;
    }
    std::fs::create_dir(&tmp).map_err(io(&tmp))?;
    let result = (|| {
        let mut st_meta = BTreeMap::new();
        st_meta.insert("step".to_string(), meta.step.to_string());
        let p = tmp.join("params.safetensors");
        params
            .save_safetensors(&p, &st_meta)
            .map_err(|e| CortexError::Checkpoint {
                path: p.clone(),
                reason: e.to_string(),
            })?;
        let o = tmp.join("optim.safetensors");
        optim
            .save_safetensors(&o, params)
            .map_err(|e| CortexError::Checkpoint {
                path: o.clone(),
                reason: e.to_string(),
            })?;
        let m = tmp.join("meta.json");
        let text = serde_json::to_string_pretty(meta).map_err(|e| CortexError::Json {
            path: m.clone(),
            source: e,
        })?;
        std::fs::write(&m, text).map_err(io(&m))?;
        Ok::<(), CortexError>(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    if fin.exists() {
        // Re-saving a step: move the old one aside first (a rename cannot replace a directory).
        let old = dir.join(format!(".{name}.old-{}", std::process::id()));
        std::fs::rename(&fin, &old).map_err(io(&fin))?;
        std::fs::rename(&tmp, &fin).map_err(io(&fin))?;
        let _ = std::fs::remove_dir_all(&old);
    } else {
        std::fs::rename(&tmp, &fin).map_err(io(&fin))?;
    }
    Ok(fin)
}

/// Reads `meta.json` of the checkpoint at `path`.
pub fn read_meta(path: &Path) -> Result<CheckpointMeta, CortexError> {
    let m = path.join("meta.json");
    let text = std::fs::read_to_string(&m).map_err(io(&m))?;
    let meta: CheckpointMeta = serde_json::from_str(&text).map_err(|e| CortexError::Json {
        path: m.clone(),
        source: e,
    })?;
    if meta.format != CHECKPOINT_FORMAT {
        return Err(CortexError::Checkpoint {
            path: m,
            reason: format!(
                "format {} is not the supported {CHECKPOINT_FORMAT}",
                meta.format
            ),
        });
    }
    Ok(meta)
}

/// Loads the parameters of the checkpoint at `path` into `params` (names and shapes must match).
pub fn load_params(path: &Path, params: &mut ParamStore<f32>) -> Result<(), CortexError> {
    let p = path.join("params.safetensors");
    params.load_into(&p).map_err(|e| CortexError::Checkpoint {
        path: p.clone(),
        reason: e.to_string(),
    })?;
    Ok(())
}

/// Loads the optimiser state of the checkpoint at `path`.
pub fn load_optim(
    path: &Path,
    optim: &mut Optimizer<f32, Adam>,
    params: &ParamStore<f32>,
) -> Result<(), CortexError> {
    let o = path.join("optim.safetensors");
    optim
        .load_safetensors(&o, params)
        .map_err(|e| CortexError::Checkpoint {
            path: o.clone(),
            reason: e.to_string(),
        })
}

/// The checkpoint of the highest step under `dir` (complete ones only), if any.
pub fn latest_checkpoint(dir: &Path) -> Result<Option<PathBuf>, CortexError> {
    if !dir.exists() {
        return Ok(None);
    }
    let mut best: Option<(u64, PathBuf)> = None;
    for entry in std::fs::read_dir(dir).map_err(io(dir))? {
        let entry = entry.map_err(io(dir))?;
        let name = entry.file_name().to_string_lossy().to_string();
        let Some(num) = name.strip_prefix("step_") else {
            continue;
        };
        let Ok(step) = num.parse::<u64>() else {
            continue;
        };
        if !entry.path().join("meta.json").exists() {
            continue;
        }
        if best.as_ref().is_none_or(|(s, _)| step > *s) {
            best = Some((step, entry.path()));
        }
    }
    Ok(best.map(|(_, p)| p))
}
