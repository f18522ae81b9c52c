//! The training loop of a run: a step, the CMF-SIM and held-out measurements on their
//! schedule, `metrics.csv` and the checkpoints, and a stop on SIGINT/SIGTERM.

use super::*;

impl RunState<'_> {
    /// The training loop: steps, checkpoints, measurements, and the end of the run.
    pub(super) fn drive(mut self) -> Result<Summary, RunError> {
        let steps = self.config.steps;
        let mut k = self.run_step();
        if self.pending_row.is_some() && self.measure(k)? {
            return self.end(k);
        }
        if self.progress.measured && self.reached_stop_dimension() {
            return self.end(k);
        }
        while k < steps {
            k += 1;
            self.during("a training step", k);
            self.train_step(k).map_err(|e| self.said_as_stop(e, k))?;
            interrupt::fault_point("step", self.trainer.step_count());
            if self.checkpoint_due(k) {
                self.save(k, false)?;
            }
            self.stop_if_asked(k, false)?;
            self.during("the step's measurements", k);
            let stop_early = self.measure(k).map_err(|e| self.said_as_stop(e, k))?;
            interrupt::fault_point("measured", self.trainer.step_count());
            self.stop_if_asked(k, true)?;
            if stop_early {
                break;
            }
        }
        self.end(k)
    }

    /// The end of the run at step `k`: its checkpoint, written before the step's measurements,
    /// is written again with them, so that a run extended later (`resume --steps`) keeps the
    /// measurement of this step in its record; then [`Self::finish`].
    fn end(mut self, k: u64) -> Result<Summary, RunError> {
        let saved_measured = matches!(&self.saved, Some((s, true, _)) if *s == k);
        if self.progress.measured && !saved_measured {
            self.save(k, true)?;
        }
        self.finish()
    }

    fn cmf_due(&self, k: u64) -> bool {
        let s = &self.config.schedule;
        self.mode.cmf_sim
            && (k == self.config.steps
                || (s.cmf_every_steps > 0 && k.is_multiple_of(s.cmf_every_steps))
                || s.cmf_extra_steps.contains(&k))
    }

    fn checkpoint_due(&self, k: u64) -> bool {
        let every = self.config.cortex.train.checkpoint_every_steps;
        k == self.config.steps || (every > 0 && k.is_multiple_of(every)) || self.cmf_due(k)
    }

    fn reached_stop_dimension(&self) -> bool {
        let target = self.config.schedule.stop_at_dimension;
        target > 0
            && self
                .progress
                .dims
                .last()
                .is_some_and(|d| d.dimension >= target)
    }

    /// One gradient update and, when due, the held-out evaluation; leaves the step's metrics
    /// row pending until its measurements.
    fn train_step(&mut self, k: u64) -> Result<(), RunError> {
        let bs = self.config.cortex.train.batch_size;
        self.source.next_batch_into(bs, &mut self.batch);
        let stats = match self.trainer.step(&self.batch) {
            Ok(s) => s,
            Err(e) => {
                self.bar.abandon_with_message("stopped");
                return Err(e.into());
            }
        };
        self.progress.step_ms_total += stats.total_ms;
        if stats.warp_coverage == 0.0 && !self.said_empty_warp {
            self.said_empty_warp = true;
            self.bar
                .suspend(|| println!("  warning: {}", empty_warp_warning(k)));
        }
        self.losses.0.push(k as f64);
        self.losses.1.push(stats.loss);
        let mut row = format!(
            "{k},{},{},{:.3}",
            stats.loss, stats.main_loss, stats.total_ms
        );
        let schedule = &self.config.schedule;
        let every = schedule.eval_every_steps;
        if k == self.config.steps || (every > 0 && k.is_multiple_of(every)) {
            let batches = schedule.eval_batches;
            let stop = interrupt::stop_flag();
            let e = heldout_error(&mut self.trainer, &mut self.heldout, bs, batches, stop)?;
            self.progress.last_eval = Some(e);
            let _ = write!(row, ",{},{},{}", e[0], e[1], e[2]);
            if self.config.cortex.m.mode != cortex::config::MMode::Oracle {
                let m =
                    heldout_motion_error(&mut self.trainer, &mut self.heldout, bs, batches, stop)?;
                self.progress.last_motion_error = Some(m);
                let _ = write!(row, ",{m}");
            } else {
                row.push(',');
            }
        } else {
            row.push_str(",,,,");
        }
        row.push_str(&crate::alignment_plot::cells(stats.alignment.as_ref()));
        self.pending_row = Some(row);
        self.bar.set_position(k);
        self.bar.set_message(format!(
            "loss {:.4} · {:.0} ms/step",
            stats.loss, stats.total_ms
        ));
        if self.bar.is_hidden() && k.is_multiple_of((self.config.steps / 10).max(1)) {
            // Not a terminal: a line every tenth of the run instead of a bar.
            println!(
                "  step {k}/{}: loss {:.4}, {:.0} ms/step",
                self.config.steps, stats.loss, stats.total_ms
            );
        }
        Ok(())
    }

    /// The measurements of step `k` (CMF-SIM, pictures) when due; completes its metrics row.
    /// Returns whether the run reached `stop_at_dimension`.
    fn measure(&mut self, k: u64) -> Result<bool, RunError> {
        let mut dimension_column = String::new();
        if self.cmf_due(k) {
            let final_step = k == self.config.steps;
            let settings = self.config.cmf_settings(final_step);
            self.bar.set_message(format!("step {k} · CMF-SIM…"));
            self.during("CMF-SIM", k);
            let r = measure(&settings, self.config, &self.source.retina, &self.trainer)?;
            let dir = self.out.join("cmf_sim").join(format!("step_{k:06}"));
            crate::io::save_into(&dir, |staging| -> Result<(), RunError> {
                r.save(staging)?;
                Ok(())
            })?;
            let measured = LastMeasurement::of(k, &r);
            // The margins say how far from the border the verdict is; an undefined one says why.
            let mut said = vec![
                margins_text(&measured.converged_ratio_per_k),
                format!("{:.0} s", r.seconds),
                format!(
                    "{} λ, {} sets/K",
                    settings.n_test_wavelengths, settings.sets_per_k
                ),
            ];
            if r.dimension == 0 {
                said.push(r.verdict.clone());
            }
            said.retain(|part| !part.is_empty());
            self.bar.suspend(|| {
                println!(
                    "  step {k}: CMF-SIM dimension {} ({})",
                    r.dimension,
                    said.join("; ")
                )
            });
            self.progress.dims.push(DimensionPoint {
                step: k,
                dimension: r.dimension,
                seconds: r.seconds,
                wall_seconds: self.started.elapsed().as_secs_f64(),
                sets_per_k: settings.sets_per_k,
                test_wavelengths: settings.n_test_wavelengths,
            });
            dimension_column = r.dimension.to_string();
            self.progress.last_cmf = Some(measured);
        }
        if let Some(row) = self.pending_row.take() {
            let _ = writeln!(self.metrics, "{row},{dimension_column}");
        }
        let every = self.config.schedule.pictures_every_steps;
        if self.mode.pictures && every > 0 && k.is_multiple_of(every) && k != self.config.steps {
            pictures::write_all(
                &self.out.join("pictures").join(format!("step_{k:06}")),
                self.config,
                &self.source.retina,
                &mut self.heldout,
                &self.trainer,
                false,
            )?;
        }
        self.progress.measured = true;
        if k.is_multiple_of(200) {
            self.write_metrics()?;
        }
        let stop = self.reached_stop_dimension();
        if stop {
            let target = self.config.schedule.stop_at_dimension;
            self.bar
                .suspend(|| println!("  reached dimension {target} at step {k}: stopping early"));
        }
        Ok(stop)
    }

    pub(super) fn write_metrics(&self) -> Result<(), RunError> {
        let mut text = self.metrics.clone();
        if let Some(row) = &self.pending_row {
            let _ = writeln!(text, "{row},");
        }
        crate::io::write_atomic(&self.out.join("metrics.csv"), text.as_bytes())?;
        Ok(())
    }

    /// Writes `metrics.csv`, then the checkpoint of step `k` with the run state.
    fn save(&mut self, k: u64, measured: bool) -> Result<PathBuf, RunError> {
        self.write_metrics()?;
        self.progress.measured = measured;
        self.progress.heldout_state = self.heldout.save_state();
        self.progress.wall_seconds = self.started.elapsed().as_secs_f64();
        self.progress.threads = Some(rayon::current_num_threads());
        self.progress.instruction_set = Some(crate::instruction_set::current().to_string());
        let state = serde_json::to_value(&self.progress).expect("plain data");
        let path = self.trainer.save_checkpoint_with(
            &self.out.join("checkpoints"),
            Some(&self.source),
            Some(state),
        )?;
        self.saved = Some((k, measured, path.clone()));
        Ok(path)
    }

    /// `e` said as a stop inside step `k` ([`RunError::said_as_stop`]): what was written is the
    /// last checkpoint, from which the run resumes.
    fn said_as_stop(&mut self, e: RunError, k: u64) -> RunError {
        self.bar.abandon_with_message("stopped");
        e.said_as_stop(|| self.kept_at(k))
    }

    /// What a stop inside step `k` keeps, and how to go on.
    fn kept_at(&self, k: u64) -> String {
        let out = self.out.display();
        let kept = match &self.saved {
            Some((s, _, path)) => format!("its last checkpoint is {} (step {s})", path.display()),
            None => "no checkpoint was written yet".to_string(),
        };
        format!(
            "step {k} is not recorded and {kept}. Continue with `colorvision resume {out}` (or \
             the same command with --resume)"
        )
    }

    /// Records, for a stop that has to leave without the stage ([`interrupt::during`]), that
    /// the run is in `stage` of step `k`.
    fn during(&self, stage: &'static str, k: u64) {
        interrupt::during(stage, self.kept_at(k));
    }

    /// After step `k` (before or after its measurements): when a signal asked to stop, make
    /// sure a checkpoint of this point exists and stop with [`RunError::Interrupted`].
    fn stop_if_asked(&mut self, k: u64, measured: bool) -> Result<(), RunError> {
        let Some(signal) = interrupt::requested() else {
            return Ok(());
        };
        interrupt::announce();
        let checkpoint = match &self.saved {
            Some((s, m, path)) if *s == k && *m == measured => path.clone(),
            _ => self.save(k, measured)?,
        };
        self.bar.abandon_with_message("stopped");
        Err(RunError::Interrupted {
            signal,
            step: k,
            steps: self.config.steps,
            checkpoint,
            run: self.out.to_path_buf(),
        })
    }
}

/// CMF-SIM with `settings` on the observer "retina + the trainer's cortex".
pub fn measure(
    settings: &CmfSimSettings,
    config: &RunConfig,
    retina: &Retina,
    trainer: &Trainer,
) -> Result<CmfSimResult, RunError> {
    let observer = EyeObserver::cortex(retina, &trainer.cortex, config.observer.clone());
    let stop = interrupt::stop_flag();
    Ok(colorimetry::run_cmf_sim_until(
        &observer,
        settings,
        &mut |_| {},
        stop,
    )?)
}

/// What a run says the first time (in this process) a step's warp mask is empty.
fn empty_warp_warning(step: u64) -> String {
    format!(
        "step {step}: the warp's mask is empty: P has moved every sampling point out of the \
         field, so the prediction loss (main_loss) is 0 and gives no gradient this step (a \
         minimum of the loss, not a fit; only cortex.loss.outside_field_weight, when set, \
         pulls the points back; docs/learning-rules.md, \"The empty warp\"). Such steps are \
         the rows of metrics.csv whose main_loss is 0."
    )
}
