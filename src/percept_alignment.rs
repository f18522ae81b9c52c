//! `colorvision percept-alignment --run A --against B`: how alike two runs' percepts of the same
//! held-out frames are at every checkpoint step both runs have (a learning rule's run against
//! backprop's), by affine R² both ways and linear CKA (`science::percept_alignment`).
//!
//! The two runs must see through one eye (the same `retina` settings): their held-out frames
//! are then the same. Output: `A/percept-alignment/against-<B's folder name>.csv` and `.json`,
//! one row a step. Evaluation only.

use crate::io::{fs_err, write_atomic, write_json};
use crate::run::error::RunError;
use crate::run::folder::{load_run_at, read_valid_config};
use cortex::DataSource;
use science::percept_alignment::{compare, PerceptAlignment};
use std::path::Path;

/// One checkpoint step of the two runs compared.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AlignmentRow {
    /// The step.
    pub step: u64,
    /// The two percepts compared.
    #[serde(flatten)]
    pub alignment: PerceptAlignment,
}

/// The checkpoint steps of the run folder `dir`, oldest first.
fn checkpoint_steps(dir: &Path) -> Result<Vec<u64>, RunError> {
    let mut steps: Vec<u64> = cortex::checkpoint::newest_first(&dir.join("checkpoints"))?
        .iter()
        .filter_map(|p| p.file_name()?.to_str()?.strip_prefix("step_")?.parse().ok())
        .collect();
    steps.sort_unstable();
    Ok(steps)
}

/// Compares runs `run` and `against` at every common checkpoint step on `batches` held-out
/// batches of `run`'s batch size; writes and returns the rows.
pub fn command(run: &Path, against: &Path, batches: usize) -> Result<Vec<AlignmentRow>, RunError> {
    let (ca, cb) = (read_valid_config(run)?, read_valid_config(against)?);
    if ca.retina != cb.retina {
        return Err(RunError::invalid(
            "retina",
            format!(
                "{} and {} see through different eyes: their held-out frames differ",
                run.display(),
                against.display()
            ),
        ));
    }
    let theirs = checkpoint_steps(against)?;
    let steps: Vec<u64> = checkpoint_steps(run)?
        .into_iter()
        .filter(|s| theirs.contains(s))
        .collect();
    if steps.is_empty() {
        return Err(RunError::invalid(
            "checkpoints",
            format!(
                "{} and {} share no checkpoint step",
                run.display(),
                against.display()
            ),
        ));
    }
    let bs = ca.cortex.train.batch_size;
    let mut source = science::heldout::heldout_source(&ca, false)?;
    let mut ons = Vec::new();
    for _ in 0..batches.max(1) {
        let batch = source.next_batch(bs);
        let mut frames = Vec::new();
        batch.frames(0, &mut frames);
        ons.extend(frames);
    }
    let total = bs * batches.max(1);
    let border_px = ca.cortex.loss.border_px;
    let mut rows = Vec::new();
    for step in steps {
        let (_, a, _) = load_run_at(run, step)?;
        let (_, b, _) = load_run_at(against, step)?;
        let alignment = compare(&a.cortex, &b.cortex, &ons, total, border_px);
        println!(
            "  step {step}: R² {against_name} from this run {:.3}, this run from it {:.3}, CKA {:.3}",
            alignment.r2_b_from_a,
            alignment.r2_a_from_b,
            alignment.cka,
            against_name = against.display()
        );
        rows.push(AlignmentRow { step, alignment });
    }
    let name = against
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "run".into());
    let out = run.join("percept-alignment");
    std::fs::create_dir_all(&out).map_err(fs_err(&out))?;
    let mut csv = String::from("step,r2_b_from_a,r2_a_from_b,cka,samples\n");
    for r in &rows {
        let a = &r.alignment;
        csv += &format!(
            "{},{},{},{},{}\n",
            r.step, a.r2_b_from_a, a.r2_a_from_b, a.cka, a.samples
        );
    }
    write_atomic(&out.join(format!("against-{name}.csv")), csv.as_bytes())?;
    write_json(&out.join(format!("against-{name}.json")), &rows)?;
    Ok(rows)
}
