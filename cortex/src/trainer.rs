//! Training: one [`Trainer`] owns the cortex, the optimiser (with its state), the step counter, an RNG
//! and the tape; [`Trainer::step`] turns one [`OnsBatch`] into one gradient update.
//!
//! - Credit assignment goes through `autodiff::learn::LearningRule` (backprop by default;
//!   [`Trainer::set_learning_rule`] swaps in any rule: one of [`crate::rule`]'s registry or a
//!   user's own). The rule receives the recorded prediction (loss, output `Ô_{t+1}`, the
//!   tape's bucket scopes and tags) and, when it asks, the cortex's local objectives
//!   ([`crate::forward_forward`]). Forward and backward time per bucket come from the tape's
//!   scopes, whatever the rule.
//! - Between the rule and the optimiser ([`crate::credit`]): every `train.alignment_every_steps` the
//!   rule's update is measured against backprop's gradient on the same tape (per bucket, in
//!   [`StepStats::alignment`]); then it is clipped per bucket and as a whole when the config
//!   says so; the optimiser ([`crate::optimizer`]: Adam or SGD) applies it with a learning-rate
//!   factor per bucket.
//! - A non-finite loss or gradient stops with [`CortexError::NonFiniteLoss`] *before* the update,
//!   so the parameters stay those of the last good step and checkpoints on disk are untouched.
//! - Checkpoints ([`crate::checkpoint`]) hold parameters, the optimiser's state, the learning rule's
//!   state, step, config, RNG and the data source's state; [`Trainer::resume`] continues
//!   bit-identically (same seed, same thread count) once the run's rule is set again. [`Trainer::continue_from`] keeps the cortex and recreates the optimiser, as the
//!   official dimensionality boosting / gene therapy does (authors' code, docs/references.md#training).
//! - Neural Scope stays outside: with [`Trainer::set_keep_percept`] the trainer keeps a detached
//!   copy of the last percept for the caller to fit; nothing flows back.

use crate::config::CortexConfig;
use crate::credit::Alignment;
use crate::data::OnsBatch;
use crate::model::Bucket;
use crate::model::{bucket_of_scope, Cortex, MotionOut, Prediction, BUCKETS, BUCKET_NAMES};
use crate::optimizer::{optimizer, CortexOptimizer};
use crate::rng::CortexRng;
use crate::CortexError;
use autodiff::learn::{AlignmentMeter, Backprop, LearningRule, Objective, ParamGrads, RuleState};
use autodiff::{Tape, Var};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What one step did and where the time went (milliseconds).
#[derive(Clone, Debug, PartialEq)]
pub struct StepStats {
    /// Steps done after this one.
    pub step: u64,
    /// The training loss (main + blurred objective when M is learned).
    pub loss: f64,
    /// The main prediction loss (authors' code, docs/references.md#loss normalisation).
    pub main_loss: f64,
    /// Forward time per bucket, indexed by [`Bucket`] (M is motion estimation).
    pub forward_ms: [f64; BUCKETS],
    /// Backward time per bucket, every sweep the rule ran (rule hooks included).
    pub backward_ms: [f64; BUCKETS],
    /// Whole credit assignment (the rule's sweeps and gradient gathering).
    pub credit_ms: f64,
    /// The optimiser's update.
    pub optimizer_ms: f64,
    /// Everything in `step`.
    pub total_ms: f64,
    /// The rule's update against backprop's gradient per bucket, when measured this step
    /// ([`crate::credit`]).
    pub alignment: Option<Alignment>,
    /// The share of the loss's sites (every batch item, every pixel inside `loss.border_px`)
    /// where the warp's validity mask is 1: how much of `O_{t+1}` the prediction was compared
    /// with. At 0, P has moved every sampling point out of the field: `main_loss` is 0 and the
    /// prediction error gives no gradient.
    pub warp_coverage: f64,
}

impl StepStats {
    /// `"W 1.2+0.8 ms, C …"`: forward+backward per bucket.
    pub fn bucket_summary(&self) -> String {
        (0..BUCKETS)
            .map(|i| {
                format!(
                    "{} {:.1}+{:.1}",
                    BUCKET_NAMES[i], self.forward_ms[i], self.backward_ms[i]
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Held-out prediction quality of one batch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PredictionError {
    /// Mean squared error of the cortex's prediction of frame t+1 (inside the border and mask).
    pub model_mse: f64,
    /// Mean squared error of "frame t+1 = frame t" over the same pixels.
    pub identity_mse: f64,
}

impl PredictionError {
    /// `identity_mse / model_mse`: how many times better than predicting no change.
    pub fn improvement(&self) -> f64 {
        self.identity_mse / self.model_mse
    }
}

/// The training loop's state.
pub struct Trainer {
    /// The model being trained.
    pub cortex: Cortex,
    pub(crate) optim: CortexOptimizer,
    pub(crate) rule: Box<dyn LearningRule<f32>>,
    pub(crate) step: u64,
    pub(crate) rng: CortexRng,
    pub(crate) tape: Tape<f32>,
    pub(crate) grads: ParamGrads<f32>,
    pub(crate) frames: [Vec<f32>; 2],
    pub(crate) keep_percept: bool,
    pub(crate) last_percept: Vec<f32>,
    pub(crate) last_batch: usize,
    pub(crate) last_checkpoint: Option<PathBuf>,
    pub(crate) continued_from_step: Option<u64>,
    pub(crate) last_loss: Option<f64>,
    /// The rule state of the checkpoint this trainer was resumed from, for the rule set next.
    pub(crate) pending_rule_state: Option<RuleState<f32>>,
    pub(crate) meter: AlignmentMeter<f32>,
}

impl Trainer {
    /// A fresh cortex from `config`, step 0.
    pub fn new(config: CortexConfig) -> Result<Self, CortexError> {
        let rng = CortexRng::seed_from(config.train.seed);
        let cortex = Cortex::new(config)?;
        let optim = optimizer(&cortex);
        Ok(Trainer {
            cortex,
            optim,
            rule: Box::new(Backprop),
            step: 0,
            rng,
            tape: Tape::new(),
            grads: ParamGrads::new(),
            frames: [Vec::new(), Vec::new()],
            keep_percept: false,
            last_percept: Vec::new(),
            last_batch: 0,
            last_checkpoint: None,
            continued_from_step: None,
            last_loss: None,
            pending_rule_state: None,
            meter: AlignmentMeter::new(),
        })
    }

    /// Gradient updates done.
    pub fn step_count(&self) -> u64 {
        self.step
    }

    /// The config.
    pub fn config(&self) -> &CortexConfig {
        &self.cortex.config
    }

    /// The trainer's RNG (seeded from `train.seed`, saved in checkpoints) for callers that need
    /// randomness tied to the run.
    pub fn rng(&mut self) -> &mut CortexRng {
        &mut self.rng
    }

    /// Replaces the credit-assignment rule (backprop at start). A trainer resumed from a
    /// checkpoint hands the rule the state saved there (its feedback matrices, counters), so
    /// the resumed run assigns exactly the credit of the run that never stopped; an error
    /// when that state is not this rule's.
    pub fn set_learning_rule(
        &mut self,
        mut rule: Box<dyn LearningRule<f32>>,
    ) -> Result<(), CortexError> {
        if let Some(state) = self.pending_rule_state.take().filter(|s| !s.is_empty()) {
            rule.load_state(&state, &self.cortex.params)
                .map_err(|e| CortexError::Checkpoint {
                    path: self
                        .last_checkpoint
                        .clone()
                        .unwrap_or_default()
                        .join(crate::checkpoint::CHECKPOINT_FILES[2]),
                    reason: format!("the learning rule's state does not fit the rule: {e}"),
                })?;
        }
        self.rule = rule;
        Ok(())
    }

    /// The learning rule's state now (what a checkpoint saves).
    pub fn learning_rule_state(&self) -> RuleState<f32> {
        self.rule.state(&self.cortex.params)
    }

    /// Turns the training tape's per-op profile on or off (see `autodiff::profile`).
    pub fn set_profiling(&mut self, on: bool) {
        self.tape.set_profiling(on);
    }

    /// The per-op times of the steps since profiling was turned on or last taken.
    pub fn take_profile(&mut self) -> autodiff::profile::Profile {
        self.tape.take_profile()
    }

    /// Keep a detached copy of each step's percept for Neural Scope ([`Trainer::last_percept`]).
    pub fn set_keep_percept(&mut self, keep: bool) {
        self.keep_percept = keep;
    }

    /// The last step's percept `V_t`, `(B, N, n, n)`, and B; empty unless kept.
    pub fn last_percept(&self) -> (&[f32], usize) {
        (&self.last_percept, self.last_batch)
    }

    /// The step at which this trainer continued another run's cortex on new data
    /// ([`Trainer::continue_from`]), if it did.
    pub fn continued_from_step(&self) -> Option<u64> {
        self.continued_from_step
    }

    /// The last checkpoint written or loaded.
    pub fn last_checkpoint(&self) -> Option<&Path> {
        self.last_checkpoint.as_deref()
    }

    pub(crate) fn check_batch(&self, batch: &OnsBatch) -> Result<(), CortexError> {
        batch.validate()?;
        if batch.n != self.cortex.n() {
            return Err(CortexError::InvalidBatch {
                field: "n",
                reason: format!(
                    "batch ONS is {0}×{0}, the cortex expects {1}×{1}",
                    batch.n,
                    self.cortex.n()
                ),
            });
        }
        Ok(())
    }

    /// Records the cortex's prediction of frame t+1 from the two frames held in `frames`
    /// (`(b, n)`: batch and ONS side) on a cleared tape; returns it and frame t+1's variable.
    pub(crate) fn record_frames(
        &mut self,
        (b, n): (usize, usize),
        motion: &MotionOut,
    ) -> (Prediction, Var) {
        self.tape.clear();
        let o1 = self.tape.constant_from([b, 1, n, n], &self.frames[0]);
        let o2 = self.tape.constant_from([b, 1, n, n], &self.frames[1]);
        let pred = self
            .cortex
            .record_prediction(&mut self.tape, o1, o2, motion);
        (pred, o2)
    }

    /// Where the step's first non-finite value was made, in words: the op, its bucket and the
    /// pass (`autodiff::Tape::trace_non_finite`; a backprop sweep on the step's tape).
    fn non_finite_site(&mut self, loss: Var) -> Option<String> {
        self.tape.trace_non_finite(loss).map(|site| {
            let bucket = site
                .scope
                .map(|b| format!(" in bucket {b}"))
                .unwrap_or_default();
            let pass = match site.pass {
                autodiff::Pass::Forward => "forward value",
                autodiff::Pass::Backward => "backward (its vector–Jacobian product)",
            };
            format!("`{}`{bucket}, {pass}", site.op)
        })
    }

    /// Stops with the op and bucket that first made a non-finite value when any parameter's
    /// gradient is not finite (named by the first such parameter).
    fn check_gradients_finite(&mut self, loss: Var) -> Result<(), CortexError> {
        let bad = self
            .grads
            .iter()
            .find(|(_, g)| g.data().iter().any(|v| !v.is_finite()))
            .map(|(id, _)| id);
        match bad {
            None => Ok(()),
            Some(id) => Err(CortexError::NonFiniteGradient {
                step: self.step + 1,
                param: self.cortex.params.name(id).to_string(),
                site: self.non_finite_site(loss),
                last_checkpoint: self.last_checkpoint.clone(),
            }),
        }
    }

    /// The mean of the warp's validity mask `(B, 1, n, n)` over the loss's sites (inside the
    /// border the loss drops): [`StepStats::warp_coverage`].
    fn warp_coverage(&self, mask: Var) -> f64 {
        let border = self.cortex.config.loss.border_px;
        let value = self.tape.value(mask);
        let (_, _, _, n) = value.shape().bchw("the warp mask");
        let inner = n.saturating_sub(2 * border);
        let mut sum = 0.0;
        for plane in value.data().chunks(n * n) {
            for row in plane.chunks(n).skip(border).take(inner) {
                sum += row[border..border + inner]
                    .iter()
                    .map(|&m| m as f64)
                    .sum::<f64>();
            }
        }
        sum / (value.data().len() / (n * n) * inner * inner).max(1) as f64
    }

    /// One gradient update from `batch`.
    pub fn step(&mut self, batch: &OnsBatch) -> Result<StepStats, CortexError> {
        let t0 = Instant::now();
        self.check_batch(batch)?;
        let (b, n) = (batch.batch, batch.n);
        let mut fwd = [0.0; BUCKETS];
        batch.frames(0, &mut self.frames[0]);
        batch.frames(1, &mut self.frames[1]);
        let tm = Instant::now();
        let motion = self.cortex.estimate_motion(
            &self.frames[0],
            &self.frames[1],
            batch.oracle_motion.as_deref(),
        )?;
        fwd[Bucket::M as usize] = tm.elapsed().as_secs_f64() * 1e3;

        let (pred, o2) = self.record_frames((b, n), &motion);
        if self.rule.needs_local_losses() {
            crate::forward_forward::record_local_losses(
                &self.cortex,
                &mut self.tape,
                &pred,
                o2,
                &motion,
                self.rule.local_objective(),
            );
        }
        let measure = self.alignment_due();
        let loss = self.tape.value(pred.loss).item() as f64;
        let main_loss = self.tape.value(pred.main_loss).item() as f64;
        let warp_coverage = self.warp_coverage(pred.mask);
        if !loss.is_finite() {
            return Err(CortexError::NonFiniteLoss {
                step: self.step + 1,
                value: loss,
                site: self.non_finite_site(pred.loss),
                last_checkpoint: self.last_checkpoint.clone(),
            });
        }
        if self.keep_percept {
            self.last_percept.clear();
            self.last_percept
                .extend_from_slice(self.tape.value(pred.percept).data());
            self.last_batch = b;
        }

        let tc = Instant::now();
        self.rule.assign_credit_into(
            &mut self.tape,
            Objective::with_output(pred.loss, pred.predicted),
            &self.cortex.params,
            &mut self.grads,
        );
        let credit_ms = tc.elapsed().as_secs_f64() * 1e3;
        let times = self.tape.scope_times();
        let mut bwd = [0.0; BUCKETS];
        let by_bucket = |list: &[(&'static str, f64)], into: &mut [f64; BUCKETS]| {
            for &(scope, ms) in list {
                if let Some(b) = bucket_of_scope(scope) {
                    into[b as usize] += ms;
                }
            }
        };
        by_bucket(&times.forward_ms, &mut fwd);
        by_bucket(&times.backward_ms, &mut bwd);
        self.check_gradients_finite(pred.loss)?;
        let alignment = measure.then(|| self.measure_alignment(pred.loss));
        self.clip_update();
        let to = Instant::now();
        let learning_rate = self.cortex.config.train.learning_rate_at(self.step);
        self.optim
            .step(learning_rate, &mut self.cortex.params, &self.grads)
            .map_err(|e| CortexError::InvalidConfig {
                field: "optimizer".into(),
                reason: e.to_string(),
            })?;
        let optimizer_ms = to.elapsed().as_secs_f64() * 1e3;
        self.step += 1;
        self.last_loss = Some(loss);

        Ok(StepStats {
            step: self.step,
            loss,
            main_loss,
            forward_ms: fwd,
            backward_ms: bwd,
            credit_ms,
            optimizer_ms,
            total_ms: t0.elapsed().as_secs_f64() * 1e3,
            alignment,
            warp_coverage,
        })
    }
}
