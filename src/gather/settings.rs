//! The settings a gathered run is shown and matched by: its resolved config flattened to
//! dotted keys ([`flatten`]) and, for a run that continued another run's cortex, the setting
//! [`CONTINUED_FROM_KEY`] naming that run — by its row among the gathered runs, or by the
//! record a gathered folder was copied to ([`RECORD_FILE`]) — and, for a record run under a
//! protocol fixed in advance, the setting [`PROTOCOL_KEY`] naming it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The file of a run record naming the folder the run was trained in and, for a run whose
/// settings a protocol fixed before it ran, that protocol: `{"trained_in": PATH}` or
/// `{"trained_in": PATH, "protocol": "PAGE @ COMMIT"}`. `scripts/record-run.sh` writes PATH,
/// and the checkpoint path in the record's `run.json`, relative to the repository root, so
/// `gather` links a recorded run to the record it continued when run from that root.
pub const RECORD_FILE: &str = "record.json";

#[derive(serde::Deserialize)]
struct Record {
    trained_in: PathBuf,
    #[serde(default)]
    protocol: Option<String>,
}

fn read_record(dir: &Path) -> Option<Record> {
    let text = std::fs::read_to_string(dir.join(RECORD_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

/// The folder the run recorded in `dir` was trained in, when `dir` holds a readable
/// [`RECORD_FILE`].
pub(super) fn recorded_from(dir: &Path) -> Option<PathBuf> {
    Some(read_record(dir)?.trained_in)
}

/// `path` canonical when it exists here, else as written (a record's training folder may be
/// on another machine).
pub(super) fn comparable(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}

/// The setting naming the run a continued run's cortex came from.
pub const CONTINUED_FROM_KEY: &str = "continued_from";

/// The setting naming the protocol that fixed a recorded run before it ran (its page and the
/// commit that added it, from the record's [`RECORD_FILE`]); absent from a run measured before
/// any protocol.
pub const PROTOCOL_KEY: &str = "protocol";

/// The settings of the run in `dir` whose resolved config is `config`, flattened to dotted keys
/// ([`flatten`]), with [`CONTINUED_FROM_KEY`] when its cortex came from another run (named by
/// its row in `rows` when it is there, [`continued_from`]). What `gather` shows and what the
/// paper's figure for the run is looked up by ([`science::paper::reported_for_settings`]: the
/// paper's figures for a continued run are those of a fresh one), and with [`PROTOCOL_KEY`] when
/// its record names the protocol it was run under.
pub(crate) fn run_settings(
    dir: &Path,
    config: &toml::Value,
    rows: &BTreeMap<PathBuf, String>,
) -> BTreeMap<String, String> {
    let mut settings = flatten(config);
    if let Some(from) = continued_from(dir, rows) {
        settings.insert(CONTINUED_FROM_KEY.into(), from);
    }
    if let Some(protocol) = read_record(dir).and_then(|r| r.protocol) {
        settings.insert(PROTOCOL_KEY.into(), protocol);
    }
    settings
}

/// `RUN @ STEP` for a run continued from `…/RUN/checkpoints/step_<STEP>`, RUN being that
/// run's row when it is among `rows` (canonical folder, or a record's training folder, → row
/// name), else its folder name; the checkpoint's path as given when it is not laid out so.
/// `None` for a fresh cortex or no `run.json`.
fn continued_from(dir: &Path, rows: &BTreeMap<PathBuf, String>) -> Option<String> {
    let text = std::fs::read_to_string(dir.join("run.json")).ok()?;
    let marker: crate::run::RunMarker = serde_json::from_str(&text).ok()?;
    let checkpoint = marker.origin_checkpoint(dir)?;
    let step = checkpoint
        .file_name()
        .and_then(|n| n.to_str()?.strip_prefix("step_")?.parse::<u64>().ok());
    let run = checkpoint
        .parent()
        .filter(|p| p.file_name().is_some_and(|n| n == "checkpoints"))
        .and_then(|p| p.parent());
    let name = run.and_then(|r| {
        let row = rows.get(&comparable(r)).cloned();
        row.or_else(|| Some(r.file_name()?.to_string_lossy().into_owned()))
    });
    Some(match (name, step) {
        (Some(name), Some(step)) => format!("{name} @ {step}"),
        _ => checkpoint.display().to_string(),
    })
}

/// `{a = {b = 1}}` as `a.b → "1"` (strings unquoted, arrays as TOML text).
pub fn flatten(value: &toml::Value) -> BTreeMap<String, String> {
    fn walk(v: &toml::Value, prefix: &str, out: &mut BTreeMap<String, String>) {
        match v {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(v, &key, out);
                }
            }
            toml::Value::String(s) => {
                out.insert(prefix.to_string(), s.clone());
            }
            other => {
                out.insert(prefix.to_string(), other.to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(value, "", &mut out);
    out
}
