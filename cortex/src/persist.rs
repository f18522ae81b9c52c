//! Checkpoints of a [`Trainer`], exact resume, continuing on a new data source, and the run
//! loop with periodic checkpoints (see [`crate::checkpoint`] for the files).

use crate::checkpoint::{self, CheckpointMeta, CHECKPOINT_FORMAT};
use crate::config::CortexConfig;
use crate::data::DataSource;
use crate::optimizer::optimizer;
use crate::rng::CortexRng;
use crate::trainer::{StepStats, Trainer};
use crate::CortexError;
use std::path::{Path, PathBuf};

/// What [`Trainer::resume_latest`] found.
pub struct Resumed {
    /// The resumed trainer and its checkpoint's metadata; `None` when no checkpoint loaded.
    pub trainer: Option<(Trainer, CheckpointMeta)>,
    /// Newer checkpoints that failed to load, newest first, with the error.
    pub skipped: Vec<(PathBuf, CortexError)>,
}

impl Trainer {
    /// The metadata a checkpoint of the current state would carry.
    pub fn checkpoint_meta(&self, source: Option<&dyn DataSource>) -> CheckpointMeta {
        CheckpointMeta {
            format: CHECKPOINT_FORMAT,
            step: self.step,
            config: self.cortex.config.clone(),
            rng: self.rng.clone(),
            data_source_state: source.and_then(|s| s.save_state()),
            continued_from_step: self.continued_from_step,
            last_loss: self.last_loss,
            run_state: None,
            files_sha256: Default::default(),
            meta_sha256: None,
        }
    }

    /// Writes a checkpoint of the current step under `dir` (atomically) and remembers it as the
    /// last good one. Pass the data source to make the resume exact.
    pub fn save_checkpoint(
        &mut self,
        dir: &Path,
        source: Option<&dyn DataSource>,
    ) -> Result<PathBuf, CortexError> {
        self.save_checkpoint_with(dir, source, None)
    }

    /// [`Trainer::save_checkpoint`] with the caller's own state (`run_state`, restored by the
    /// caller from [`CheckpointMeta::run_state`] on resume).
    pub fn save_checkpoint_with(
        &mut self,
        dir: &Path,
        source: Option<&dyn DataSource>,
        run_state: Option<serde_json::Value>,
    ) -> Result<PathBuf, CortexError> {
        let mut meta = self.checkpoint_meta(source);
        meta.run_state = run_state;
        let rule = self.rule.state(&self.cortex.params);
        let state = checkpoint::CheckpointState {
            params: &self.cortex.params,
            optim: &self.optim,
            rule: &rule,
        };
        let path = checkpoint::write_checkpoint(dir, &meta, &state)?;
        self.last_checkpoint = Some(path.clone());
        Ok(path)
    }

    /// Rebuilds the trainer of the checkpoint at `path`: parameters, optimiser state, step, RNG; and
    /// restores `source`'s state when the checkpoint holds one. The learning rule's state is
    /// kept and handed to the rule given next to [`Trainer::set_learning_rule`] (the trainer
    /// starts with backprop, which keeps none). Continuing from here gives bit-identical
    /// parameters to a run that never stopped (same thread count). Every checksum is verified
    /// first ([`checkpoint::verify`]).
    pub fn resume(
        path: &Path,
        source: Option<&mut dyn DataSource>,
    ) -> Result<Trainer, CortexError> {
        let (t, meta) = Self::load_verified(path)?;
        if let (Some(src), Some(state)) = (source, meta.data_source_state.as_ref()) {
            src.load_state(state)?;
        }
        Ok(t)
    }

    /// The trainer of the checkpoint at `path` after [`checkpoint::verify`], and its metadata
    /// (the data source is not touched).
    fn load_verified(path: &Path) -> Result<(Trainer, CheckpointMeta), CortexError> {
        let meta = checkpoint::verify(path)?;
        let mut t = Trainer::new(meta.config.clone())?;
        checkpoint::load_params(path, &mut t.cortex.params)?;
        checkpoint::load_optim(path, &mut t.optim, &t.cortex.params)?;
        t.pending_rule_state = checkpoint::load_rule_state(path, &meta)?;
        t.step = meta.step;
        t.rng = meta.rng.clone();
        t.continued_from_step = meta.continued_from_step;
        t.last_loss = meta.last_loss;
        t.last_checkpoint = Some(path.to_path_buf());
        Ok((t, meta))
    }

    /// [`Trainer::resume`] from the newest checkpoint under `dir` that loads, falling back to
    /// older ones (`trainer: None` when none does). The newer checkpoints that failed are in
    /// [`Resumed::skipped`] with the reason.
    pub fn resume_latest(
        dir: &Path,
        mut source: Option<&mut dyn DataSource>,
    ) -> Result<Resumed, CortexError> {
        let mut skipped = Vec::new();
        for path in checkpoint::newest_first(dir)? {
            match Self::load_verified(&path) {
                Ok((t, meta)) => {
                    if let (Some(src), Some(state)) =
                        (source.as_deref_mut(), &meta.data_source_state)
                    {
                        src.load_state(state)?;
                    }
                    return Ok(Resumed {
                        trainer: Some((t, meta)),
                        skipped,
                    });
                }
                Err(e) => skipped.push((path, e)),
            }
        }
        Ok(Resumed {
            trainer: None,
            skipped,
        })
    }

    /// Keeps training the cortex of the checkpoint at `path` on a **new** data source
    /// (dimensionality boosting, gene therapy; authors' code, docs/references.md#training): parameters are loaded, the optimiser is
    /// recreated (its state is not restored, as official), the step count continues.
    /// `config` may change training settings (steps, learning rate, M); the buckets' shapes
    /// must match the checkpoint. A checkpoint with its parameters only loads
    /// ([`checkpoint::verify_params`]); readings load checkpoints through here.
    pub fn continue_from(
        path: &Path,
        config: Option<CortexConfig>,
    ) -> Result<Trainer, CortexError> {
        let meta = checkpoint::verify_params(path)?;
        let cfg = config.unwrap_or_else(|| meta.config.clone());
        let mut t = Trainer::new(cfg)?;
        checkpoint::load_params(path, &mut t.cortex.params)?;
        t.optim = optimizer(&t.cortex);
        t.step = meta.step;
        t.rng = CortexRng::seed_from(t.cortex.config.train.seed ^ meta.step);
        t.continued_from_step = Some(meta.step);
        t.last_checkpoint = Some(path.to_path_buf());
        Ok(t)
    }

    /// Runs `steps` updates from `source`, writing a checkpoint every
    /// `train.checkpoint_every_steps` and at the end when `checkpoint_dir` is given; calls
    /// `on_step` after each update. Stops at the first error (a non-finite loss included) with
    /// the checkpoints already written intact.
    pub fn run(
        &mut self,
        source: &mut dyn DataSource,
        steps: u64,
        checkpoint_dir: Option<&Path>,
        mut on_step: impl FnMut(&StepStats, &Trainer),
    ) -> Result<(), CortexError> {
        let every = self.cortex.config.train.checkpoint_every_steps;
        let bs = self.cortex.config.train.batch_size;
        let mut batch = crate::data::OnsBatch::default();
        for k in 0..steps {
            source.next_batch_into(bs, &mut batch);
            let stats = self.step(&batch)?;
            on_step(&stats, self);
            if let Some(dir) = checkpoint_dir {
                let last = k + 1 == steps;
                if last || (every > 0 && self.step.is_multiple_of(every)) {
                    self.save_checkpoint(dir, Some(&*source))?;
                }
            }
        }
        Ok(())
    }
}
