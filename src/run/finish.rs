//! The end of a run: the plots, the final pictures, the top-level CMF-SIM files and
//! `summary.json`; and what the command line prints about the run folder.

use super::*;

impl RunState<'_> {
    /// After the last step: plots, final pictures, the top-level CMF-SIM files, summary.json.
    pub(super) fn finish(mut self) -> Result<Summary, RunError> {
        self.bar.finish_and_clear();
        let out = self.out;
        self.write_metrics()?;
        let mut loss_plot = LinePlot::new(
            "Training loss (normalised as the authors' code)",
            "step",
            "loss",
        );
        loss_plot.y.log = true;
        loss_plot.push(Series::new(
            "loss",
            std::mem::take(&mut self.losses.0),
            std::mem::take(&mut self.losses.1),
        ));
        crate::io::write_atomic(&out.join("loss.svg"), loss_plot.to_svg().as_bytes())?;
        let dims = &self.progress.dims;
        if !dims.is_empty() {
            let mut p = LinePlot::new(
                "Colour dimensionality over training (CMF-SIM)",
                "step",
                "dimension",
            );
            // An integer axis from "undefined" (0: no primary set passed) to the largest.
            p.y = Scale {
                integer: true,
                names: vec![(0.0, "undefined".into())],
                ..Scale::default()
            };
            p.x.integer = true;
            let top = dims.iter().map(|d| d.dimension).max().unwrap_or(1).max(1);
            (p.y_min, p.y_max) = (Some(-0.25), Some(top as f64 + 0.25));
            (p.x_min, p.x_max) = (Some(0.0), Some(self.config.steps as f64));
            p.push(
                Series::new(
                    "CMF-SIM dimension",
                    dims.iter().map(|d| d.step as f64).collect(),
                    dims.iter().map(|d| d.dimension as f64).collect(),
                )
                .steps(),
            );
            crate::io::write_atomic(&out.join("dimension.svg"), p.to_svg().as_bytes())?;
        }
        let invariants = if self.mode.pictures {
            Some(pictures::write_all(
                &out.join("pictures"),
                self.config,
                &self.source.retina,
                &mut self.heldout,
                &self.trainer,
            )?)
        } else {
            None
        };
        if let Some(last) = &self.progress.last_cmf {
            publish_top_level(out, last.step)?;
        }
        let summary = self.summary(invariants);
        crate::io::write_json(&out.join("summary.json"), &summary)?;
        crate::report::write(out, &summary)?;
        Ok(summary)
    }

    fn summary(&self, invariants: Option<pictures::Invariants>) -> Summary {
        let p = &self.progress;
        let mut first = Vec::new();
        for d in &p.dims {
            if d.dimension > 0 && !first.iter().any(|&(k, _, _)| k == d.dimension) {
                first.push((d.dimension, d.step, d.wall_seconds));
            }
        }
        let steps_done = self.trainer.step_count();
        let steps_here = self.run_step();
        Summary {
            dimension: p.last_cmf.as_ref().map_or(0, |r| r.dimension),
            steps: steps_done,
            resumed_at_steps: p.resumed_at_steps.clone(),
            wall_seconds: self.started.elapsed().as_secs_f64(),
            mean_step_ms: p.step_ms_total / steps_here.max(1) as f64,
            oracle_motion: self.config.oracle_motion,
            dimension_over_steps: p.dims.clone(),
            first_step_at_dimension: first,
            heldout_prediction: p.last_eval,
            heldout_motion_error_px: p.last_motion_error,
            verdict: p
                .last_cmf
                .as_ref()
                .map_or_else(|| "not measured".to_string(), |r| r.verdict.clone()),
            cmf_sim_per_k: p
                .last_cmf
                .as_ref()
                .map_or_else(Vec::new, |r| r.cmf_sim_per_k.clone()),
            converged_ratio_per_k: p
                .last_cmf
                .as_ref()
                .map_or_else(Vec::new, |r| r.converged_ratio_per_k.clone()),
            invariants,
            config: self.config.clone(),
        }
    }
}

/// Copies the files of the CMF-SIM measurement at `step` (`cmf_sim/step_<k>/`) to the top
/// of the run folder, each atomically.
fn publish_top_level(out: &Path, step: u64) -> Result<(), RunError> {
    let dir = out.join("cmf_sim").join(format!("step_{step:06}"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(crate::io::fs_err(&dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    for f in files {
        let name = f.file_name().expect("a file has a name");
        crate::io::copy_atomic(&f, &out.join(name))?;
    }
    Ok(())
}

/// Prints what the run folder holds.
pub fn print_outcome(out: &Path, summary: &Summary) {
    println!();
    println!("Run folder: {}", out.display());
    println!(
        "  summary.json      dimension = {} after {} steps ({:.0} s, {:.0} ms/step)",
        summary.dimension, summary.steps, summary.wall_seconds, summary.mean_step_ms
    );
    if let Some([m, i, r]) = summary.heldout_prediction {
        println!("  held-out prediction error {m:.4e} vs {i:.4e} for \"next frame = this frame\" ({r:.1}× better)");
    }
    if let Some(m) = summary.heldout_motion_error_px {
        println!("  motion estimate vs true motion on held-out batches: mean error {m:.2} ONS px");
    }
    if let Some(inv) = &summary.invariants {
        let axis = |a: &Option<colorimetry::HueAxis>| match a {
            Some(a) => format!("{:.0}° (minor/major {:.2})", a.angle_deg, a.minor_to_major),
            None => "none".into(),
        };
        println!("  learned invariants against the eye's truth:");
        for line in inv.recovery.describe() {
            println!("    {line}");
        }
        println!(
            "  Neural-Scope hue axis {} (scenes: {})",
            axis(&inv.scope_hue_axis),
            axis(&inv.truth_hue_axis),
        );
    }
    for (d, s, t) in &summary.first_step_at_dimension {
        println!("  first measured {d}-D at step {s} ({t:.0} s into the run)");
    }
    println!(
        "  cmf_sim.json/svg  CMF-SIM errors per wavelength for 0..K primaries; {}",
        summary.verdict
    );
    for line in &summary.cmf_sim_per_k {
        println!("    {line}");
    }
    println!("  dimension.svg     dimension over training;  loss.svg  training loss");
    println!("  pictures/         ONS, Neural-Scope percept beside the truth, learned C, P positions, W kernel");
    println!("  metrics.csv, checkpoints/, config.toml");
}

/// The run folder for `config` and an optional `--out`.
pub fn out_dir(config: &RunConfig, out: Option<&PathBuf>, command: &str) -> PathBuf {
    out.cloned().unwrap_or_else(|| config.default_out(command))
}
