//! Opening a run: its state built fresh, continued from another run's checkpoint, or resumed
//! from the newest checkpoint of its own folder that verifies, and the learning rule drawn
//! from the run's seed.

use super::*;

impl<'a> RunState<'a> {
    /// Steps of this run done: the trainer's steps, less those of the run it continued.
    pub(super) fn run_step(&self) -> u64 {
        self.trainer.step_count() - self.trainer.continued_from_step().unwrap_or(0)
    }

    /// Builds the trainer and the streams: fresh (or continued from `origin`), or resumed from
    /// the newest checkpoint of `out` that verifies.
    pub(super) fn open(
        config: &'a RunConfig,
        out: &'a Path,
        mode: RunMode,
        resume: bool,
        origin: Origin<'_>,
        (mut source, heldout): (RetinaSource, RetinaSource),
    ) -> Result<Self, RunError> {
        let resumed = if resume {
            resume_trainer(out, &mut source)?
        } else {
            None
        };
        let was_resumed = resumed.is_some();
        let (mut trainer, progress) = match resumed {
            Some(x) => x,
            None => {
                if let Origin::Continue(checkpoint) = origin {
                    println!(
                        "  continuing the cortex of {} on cones `{}`",
                        checkpoint.display(),
                        config.cones
                    );
                }
                (new_trainer(config, origin)?, Progress::default())
            }
        };
        if !config.learning_rule.is_backprop() {
            let rule = learning_rule(config, &trainer, was_resumed, origin)?;
            trainer.set_learning_rule(rule)?;
        }
        let mut state = RunState {
            config,
            out,
            mode,
            trainer,
            source,
            heldout,
            batch: cortex::OnsBatch::default(),
            progress,
            metrics: METRICS_HEADER.to_string(),
            pending_row: None,
            losses: (Vec::new(), Vec::new()),
            started: Instant::now(),
            bar: ProgressBar::hidden(),
            saved: None,
            said_empty_warp: false,
        };
        let resumed_at = was_resumed.then(|| state.run_step());
        if resumed_at.is_some() {
            state.restore()?;
        }
        state.announce(resumed_at);
        Ok(state)
    }

    /// Puts back what the checkpoint of `step` recorded beside the trainer: the held-out
    /// stream, the clock, and `metrics.csv` up to that step.
    fn restore(&mut self) -> Result<(), RunError> {
        let step = self.run_step();
        if let Some(state) = &self.progress.heldout_state {
            self.heldout.load_state(state)?;
        }
        self.started = Instant::now()
            .checked_sub(Duration::from_secs_f64(self.progress.wall_seconds))
            .unwrap_or_else(Instant::now);
        let path = self.out.join("metrics.csv");
        let text = std::fs::read_to_string(&path).map_err(crate::io::fs_err(&path))?;
        let mut last = 0;
        for line in text.lines().skip(1) {
            let mut cols = line.split(',');
            let k: u64 = cols.next().and_then(|c| c.parse().ok()).unwrap_or(u64::MAX);
            if k > step {
                break;
            }
            if k != last + 1 {
                return Err(RunError::Folder {
                    path: path.clone(),
                    reason: format!("row of step {k} follows step {last}: the file was changed"),
                });
            }
            last = k;
            let loss: f64 = cols.next().and_then(|c| c.parse().ok()).unwrap_or(f64::NAN);
            self.losses.0.push(k as f64);
            self.losses.1.push(loss);
            self.metrics.push_str(line);
            self.metrics.push('\n');
        }
        if last != step {
            return Err(RunError::Folder {
                path,
                reason: format!("has rows up to step {last}, the checkpoint is at step {step}"),
            });
        }
        if !self.progress.measured && step > 0 {
            // The checkpoint was taken before the step's measurements: its row waits for them.
            let row_end = self.metrics[..self.metrics.len() - 1]
                .rfind('\n')
                .map_or(0, |i| i + 1);
            let row = self.metrics.split_off(row_end);
            let without_dimension = row.trim_end().rsplit_once(',').map_or("", |(r, _)| r);
            self.pending_row = Some(without_dimension.to_string());
        }
        self.progress.resumed_at_steps.push(step);
        Ok(())
    }

    fn announce(&mut self, resumed_at: Option<u64>) {
        let c = self.config;
        println!(
            "colorvision: preset `{}`, cones `{}`, seed {}, {} steps → {}",
            c.preset,
            c.cones,
            c.seed,
            c.steps,
            self.out.display()
        );
        if let Some(step) = resumed_at {
            println!(
                "  resuming at step {step} (checkpoint {})",
                self.trainer
                    .last_checkpoint()
                    .map_or_else(String::new, |p| p.display().to_string())
            );
            let now = rayon::current_num_threads();
            if let Some(warning) = thread_count_change(self.progress.threads, now) {
                println!("  warning: {warning}");
            }
            let cpu = crate::instruction_set::current();
            let recorded = self.progress.instruction_set.as_deref();
            if let Some(warning) = crate::instruction_set::change(recorded, cpu) {
                println!("  warning: {warning}");
            }
        }
        if c.oracle_motion {
            println!("  note: the cortex receives the ORACLE eye motion (true shift) besides the optic nerve signal");
        } else {
            println!(
                "  the cortex receives the optic nerve signal only (eye motion estimated by bucket M)"
            );
        }
        if c.oracle_w_start {
            println!("  DIAGNOSTIC: W starts at the eye's true lateral-inhibition kernel (not a learning result)");
        }
        if let Some(mix) = &c.retina.scenes.tetra {
            println!(
                "  scenes: natural, with {:.0} % of the tiles holding {} (one of the environments \
                 of paper S-07)",
                100.0 * mix.fraction,
                mix.environment.describe()
            );
            if !mix.hue_rule.is_default() {
                println!(
                    "  hue-sphere colours: hues drawn evenly in a max basis, each the most \
                     chromatic surface of its hue (retina.scenes.tetra.hue_rule = max_chroma)"
                );
            }
        }
        if !c.learning_rule.is_backprop() {
            println!(
                "  learning rule: {}",
                cortex::rule::describe(&c.learning_rule, &c.rule)
            );
        }
        let retina = &self.source.retina;
        println!(
            "  retina: {} cones per side, classes {:?}",
            retina.n(),
            retina
                .mosaic
                .classes
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
        );
        self.bar = if self.mode.progress {
            ProgressBar::new(c.steps)
        } else {
            ProgressBar::hidden()
        };
        self.bar.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
                .expect("a valid template")
                .progress_chars("=> "),
        );
        self.bar
            .set_position(self.trainer.step_count().min(c.steps));
    }
}

/// A fresh trainer, or one continued from another run's checkpoint: the state the run starts
/// from, the same each time it is built.
fn new_trainer(config: &RunConfig, origin: Origin<'_>) -> Result<Trainer, RunError> {
    Ok(match origin {
        Origin::New => {
            let mut cortex_config = config.cortex.clone();
            cortex_config.train.steps = config.steps;
            let mut trainer = Trainer::new(cortex_config)?;
            if config.oracle_w_start {
                start_w_at_the_eyes_kernel(config, &mut trainer)?;
            }
            trainer
        }
        Origin::Continue(checkpoint) => {
            Trainer::continue_from(checkpoint, Some(config.cortex.clone()))?
        }
    })
}

/// A diagnostic (`oracle_w_start`): sets the cortex's W to the eye's true lateral-inhibition
/// kernel, read from the eye as no learning run does.
pub fn start_w_at_the_eyes_kernel(
    config: &RunConfig,
    trainer: &mut Trainer,
) -> Result<(), RunError> {
    let retina = retina::Retina::new(config.retina.clone())?;
    let Some((dog, size)) = retina.dog_kernel() else {
        return Err(RunError::invalid(
            "retina.lateral_inhibition",
            "this eye has no lateral inhibition to start W from",
        ));
    };
    let kernel = autodiff::Tensor::from_vec([size, size], dog.to_vec());
    if !trainer.cortex.set_w_kernel(&kernel) {
        return Err(RunError::invalid(
            "cortex.w.mode",
            "W is not learned in this cortex",
        ));
    }
    Ok(())
}

/// The run's learning rule from the registry (`cortex::rule::build`), its random state drawn
/// from the run's seed (or the rule's `feedback_seed`) and fitted to the parameters the run
/// started from. A resumed run rebuilds that start ([`new_trainer`]: the seeded
/// initialisation, or the checkpoint it continued), so it draws the backward weights of the
/// run that never stopped; the state saved in the checkpoint is then restored over it
/// (`cortex::Trainer::set_learning_rule`).
fn learning_rule(
    config: &RunConfig,
    trainer: &Trainer,
    resumed: bool,
    origin: Origin<'_>,
) -> Result<Box<dyn autodiff::learn::LearningRule<f32>>, RunError> {
    let build = |start: &autodiff::ParamStore<f32>| {
        let ctx = cortex::RuleContext {
            seed: config.seed,
            start,
        };
        cortex::rule::build(&config.learning_rule, &config.rule, &ctx)
    };
    Ok(if resumed {
        let start = new_trainer(config, origin)?;
        build(&start.cortex.params)?
    } else {
        build(&trainer.cortex.params)?
    })
}

/// The trainer and run state of the newest checkpoint of `out` that loads (saying which
/// newer ones did not and why), or `None` when none does.
fn resume_trainer(
    out: &Path,
    source: &mut RetinaSource,
) -> Result<Option<(Trainer, Progress)>, RunError> {
    let dir = out.join("checkpoints");
    let resumed = Trainer::resume_latest(&dir, Some(source))?;
    for (path, e) in &resumed.skipped {
        println!(
            "  checkpoint {} does not load ({e}); falling back to the one before",
            path.display()
        );
    }
    let Some((trainer, meta)) = resumed.trainer else {
        println!("  no checkpoint of this run loads: starting it from the beginning");
        return Ok(None);
    };
    let progress = match meta.run_state {
        Some(v) => serde_json::from_value(v).map_err(|e| RunError::Folder {
            path: meta_path(&trainer),
            reason: format!("field `run_state`: {e}"),
        })?,
        None => Progress::default(),
    };
    Ok(Some((trainer, progress)))
}

fn meta_path(trainer: &Trainer) -> PathBuf {
    trainer
        .last_checkpoint()
        .map_or_else(PathBuf::new, |p| p.join("meta.json"))
}

/// The warning for a run resumed with another thread count than its checkpoint was written
/// with: rayon splits sums by thread, so its steps from here differ in the last bits from an
/// unbroken run's. `None` when the counts agree or the checkpoint did not record one.
fn thread_count_change(recorded: Option<usize>, now: usize) -> Option<String> {
    let recorded = recorded?;
    (recorded != now).then(|| {
        format!(
            "the checkpoint was written with {recorded} worker thread(s), the run goes on \
             with {now}: it continues the same training, not bit for bit the unbroken run \
             (RAYON_NUM_THREADS={recorded} gives that)"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::thread_count_change;

    #[test]
    fn a_resume_with_another_thread_count_warns_and_names_both_counts() {
        let warning = thread_count_change(Some(1), 2).expect("1 → 2 threads is a change");
        assert!(
            warning.contains("written with 1 worker thread(s)"),
            "{warning}"
        );
        assert!(warning.contains("goes on with 2"), "{warning}");
        assert!(warning.contains("RAYON_NUM_THREADS=1"), "{warning}");
        assert_eq!(thread_count_change(Some(2), 2), None);
        assert_eq!(
            thread_count_change(None, 2),
            None,
            "older checkpoints record no count"
        );
    }
}
