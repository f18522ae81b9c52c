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
        crate::alignment_plot::write_plot(out)?;
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
            let top = dims.iter().map(|d| d.dimension).max().unwrap_or(1).max(1);
            (p.y_min, p.y_max) = (Some(-0.25), Some(top as f64 + 0.25));
            // Log-spaced measurements (paper Fig. 3.3: 1-D at 700 steps, 2-D at 1 200, 3-D far
            // later) on a log axis when they span more than a decade.
            let first = dims.iter().map(|d| d.step).min().unwrap_or(1).max(1) as f64;
            let last = (self.config.steps as f64).max(first);
            if last >= 10.0 * first {
                p.x.log = true;
                (p.x_min, p.x_max) = (Some(first), Some(last));
            } else {
                p.x.integer = true;
                (p.x_min, p.x_max) = (Some(0.0), Some(last));
            }
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
                true,
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

    fn summary(&self, invariants: Option<science::summary::Invariants>) -> Summary {
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
            "  Neural-Scope hue axis {} (an ideal observer with these cone classes: {}; the \
             scenes: {})",
            axis(&inv.scope_hue_axis),
            axis(&inv.ideal_hue_axis),
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
    if let Some(words) = in_words(out, summary) {
        println!();
        for line in wrap(&words, WORDS_WIDTH) {
            println!("  {line}");
        }
        println!();
    }
    println!("  dimension.svg     dimension over training;  loss.svg  training loss");
    println!("  pictures/         ONS, Neural-Scope percept beside the truth, learned C, P positions, W kernel");
    println!("  metrics.csv, checkpoints/, config.toml");
}

/// CMF-SIM's verdict of the run in plain words, beside what the paper reports for the same
/// retina ([`science::paper`]); `None` when the run measured no dimension.
pub fn in_words(out: &Path, summary: &Summary) -> Option<String> {
    if summary.dimension_over_steps.is_empty() {
        return None;
    }
    let d = summary.dimension;
    let found = match d {
        0 => "CMF-SIM found no colour dimension: the same light looks more different at two \
              places on this retina than a light looks from black, so the cortex has no colour \
              constancy to match colours against."
            .to_string(),
        1 => "CMF-SIM found this cortex's colour vision 1-dimensional: every test light shown at \
              one place on the retina was matched at another by one primary at some intensity, \
              as closely as the cortex tells the same light at two places apart."
            .to_string(),
        _ => format!(
            "CMF-SIM found this cortex's colour vision {d}-dimensional: every test light shown \
             at one place on the retina was matched at another by a mix of {d} primaries, as \
             closely as the cortex tells the same light at two places apart, and no mix of {} \
             did.",
            d - 1
        ),
    };
    let config = toml::Value::try_from(&summary.config).ok()?;
    let settings = crate::gather::run_settings(out, &config, &Default::default());
    let paper = match science::paper::reported_for_settings(&settings) {
        None => "The paper has no figure for this retina.".to_string(),
        Some(p) if p.agrees_with(d) => {
            format!("The paper reports {p} for this retina too.")
        }
        Some(p) => format!(
            "The paper reports {p} for this retina, for a cortex trained about 100 000 steps \
             on an eye of 256×256 cones; this one trained {} steps on an eye of {n}×{n} cones \
             (docs/results.md: how the dimension changes with training and eye size).",
            grouped(summary.steps),
            n = summary.config.retina.cones_per_side
        ),
    };
    let scenes = match &summary.config.retina.scenes.tetra {
        Some(mix) => format!(
            " It learned from natural scenes with {:.0} % of the tiles holding {} (one of the \
             environments of paper S-07).",
            100.0 * mix.fraction,
            mix.environment.describe()
        ),
        None => String::new(),
    };
    Some(format!("In words: {found} {paper}{scenes}"))
}

/// Line width of the printed plain-words verdict, characters.
const WORDS_WIDTH: usize = 96;

/// `n` with its digits in groups of three, joined by no-break spaces so that [`wrap`] keeps
/// the number on one line: `80 000`, as the docs write step counts.
fn grouped(n: u64) -> String {
    science::summary::digits_grouped(n, '\u{a0}')
}

/// `text` broken at spaces (U+0020; a no-break space holds) into lines of at most `width`
/// characters (a longer word stands on its own line).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split([' ', '\n']).filter(|w| !w.is_empty()) {
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.chars().count() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// The run folder for `config` and an optional `--out`.
pub fn out_dir(config: &RunConfig, out: Option<&PathBuf>, command: &str) -> PathBuf {
    out.cloned().unwrap_or_else(|| config.default_out(command))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_breaks_at_spaces_within_the_width() {
        let text = "CMF-SIM found this cortex's colour vision 3-dimensional: every test light";
        let lines = wrap(text, 20);
        assert!(lines.iter().all(|l| l.chars().count() <= 20), "{lines:?}");
        assert_eq!(lines.join(" "), text);
        assert_eq!(wrap("a verylongword b", 4), ["a", "verylongword", "b"]);
        assert!(wrap("", 10).is_empty());
    }

    #[test]
    fn step_counts_are_grouped_by_three_and_kept_on_one_line() {
        assert_eq!(grouped(999), "999");
        assert_eq!(grouped(6000), "6\u{a0}000");
        assert_eq!(grouped(1_234_567), "1\u{a0}234\u{a0}567");
        let text = format!("trained {} steps", grouped(80_000));
        assert_eq!(wrap(&text, 10), ["trained", "80\u{a0}000", "steps"]);
    }
}
