//! `sweep.sbatch`: the Slurm job-array script of a sweep folder, one array task per run.
//!
//! The script is plain bash with `#SBATCH` comment lines, so the same file runs a task under
//! Slurm (`sbatch DIR/sweep.sbatch`), by hand (`SLURM_ARRAY_TASK_ID=3 bash DIR/sweep.sbatch`)
//! and under `colorvision sweep --local` (which does exactly that). Each task runs
//! `colorvision sweep --task $SLURM_ARRAY_TASK_ID DIR` ([`super::task`]), which resumes its run
//! folder: a finished run is skipped and an interrupted one continues from its newest
//! checkpoint, so the array can be requeued or submitted again at any time.
//!
//! Requests: `--cpus-per-task`, `--mem` and `--time` come from the runs' presets and steps
//! ([`Resources::estimate`]); the largest over the runs is asked for every task (a job array
//! has one request). Logs go to `DIR/logs/task-<index>.log`, appended across requeues.

use super::spec::{spec_error, Job};
use science::config::{ConfigError, RunConfig};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// Array tasks running at once (`%` limit) unless the spec says otherwise.
pub const DEFAULT_CONCURRENCY: usize = 8;

/// The `[slurm]` table of a sweep spec: each field overrides the estimate.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmSettings {
    /// Array tasks running at once (the `%` limit of `--array`; default 8).
    pub concurrency: Option<usize>,
    /// CPUs per task (also the run's thread count, `RAYON_NUM_THREADS`).
    pub cpus_per_task: Option<usize>,
    /// Memory per task, MiB.
    pub mem_mib: Option<u64>,
    /// Time limit per task, minutes.
    pub time_minutes: Option<u64>,
    /// `--partition`, if the cluster needs one.
    pub partition: Option<String>,
    /// `--account`, if the cluster needs one.
    pub account: Option<String>,
}

impl SlurmSettings {
    /// Rejects zero counts and partition/account names that would break the script.
    pub fn validate(&self, spec: &Path) -> Result<(), ConfigError> {
        for (key, v) in [
            ("slurm.concurrency", self.concurrency.map(|v| v as u64)),
            ("slurm.cpus_per_task", self.cpus_per_task.map(|v| v as u64)),
            ("slurm.mem_mib", self.mem_mib),
            ("slurm.time_minutes", self.time_minutes),
        ] {
            if v == Some(0) {
                return Err(spec_error(spec, key, "must be at least 1"));
            }
        }
        for (key, v) in [
            ("slurm.partition", &self.partition),
            ("slurm.account", &self.account),
        ] {
            let ok = |s: &String| {
                !s.is_empty()
                    && s.chars()
                        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | ',' | '.'))
            };
            if v.as_ref().is_some_and(|s| !ok(s)) {
                return Err(spec_error(spec, key, "only letters, digits and _ - , ."));
            }
        }
        Ok(())
    }
}

/// What one array task asks Slurm for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Resources {
    /// CPUs per task.
    pub cpus_per_task: usize,
    /// Memory, MiB.
    pub mem_mib: u64,
    /// Time limit, minutes.
    pub time_minutes: u64,
}

/// Per preset: training-step time on 2 threads (ms), time per CMF-SIM measurement (s), the end
/// of a run per 1 024 held-out scenes (s) and memory (MiB). Step times are the README's
/// benchmarks (`cargo bench --bench cortex_step`: quick 48.4 ms with the oracle motion, sandbox
/// 31.8 ms, paper 0.9 s for the cortex and 40 ms for the retina); tiny's 6 ms and its 1 s
/// measurement are from `colorvision run --preset tiny`. CMF-SIM: quick's full budget takes
/// 156 s (README), the smaller budget during training about a minute (`config.rs`). The end:
/// the hidden figures and the own image on `schedule.held_out_scenes` scenes each, measured at
/// 1 024 beside two training runs (`/usr/bin/time colorvision train --preset P --steps 2`, and
/// `--preset paper --cones LMSQ,Q:506 --steps 1`): 10 s on `tiny` (1 s at 4 scenes), 56–68 s on
/// the quick eye, 727 s on the paper's. Memory: paper's step peaks at 1.25 GiB. `large` (4×
/// quick's cones) is taken as 4× quick in step, measurement and end time: one thread beside
/// another run, its steps took 0.39 s against quick's 0.10 s; it holds 0.9 GiB.
fn preset_costs(preset: &str) -> (f64, f64, f64, u64) {
    match preset {
        "tiny" => (6.0, 5.0, 10.0, 1024),
        "sandbox" => (31.8, 60.0, 68.0, 2048),
        "paper" => (940.0, 600.0, 727.0, 4096),
        "large" => (4.0 * 48.4, 4.0 * 160.0, 4.0 * 68.0, 2048),
        _ => (48.4, 160.0, 68.0, 2048),
    }
}

impl Resources {
    /// An estimate for one run: its steps at the preset's step time, every CMF-SIM
    /// measurement and its end's held-out measures, doubled (shared nodes, slower CPUs), plus
    /// 5 minutes; 1.5× the step time with an estimated eye motion (`config.rs`).
    pub fn estimate(config: &RunConfig, cmf_sim: bool) -> Resources {
        let (step_ms, cmf_s, end_s, mem_mib) = preset_costs(&config.preset);
        let step_ms = if config.oracle_motion {
            step_ms
        } else {
            1.5 * step_ms
        };
        let s = &config.schedule;
        let measurements = if cmf_sim {
            let periodic = config.steps.checked_div(s.cmf_every_steps).unwrap_or(0);
            periodic + s.cmf_extra_steps.len() as u64 + 1
        } else {
            0
        };
        let seconds = config.steps as f64 * step_ms / 1000.0
            + measurements as f64 * cmf_s
            + end_s * s.held_out_scenes as f64 / 1024.0;
        Resources {
            cpus_per_task: if config.preset == "tiny" { 1 } else { 2 },
            mem_mib,
            time_minutes: (2.0 * seconds / 60.0).ceil() as u64 + 5,
        }
    }

    /// The largest request over `jobs`, then the spec's overrides.
    pub fn for_jobs(jobs: &[Job], cmf_sim: bool, given: &SlurmSettings) -> Resources {
        let mut r = Resources {
            cpus_per_task: 1,
            mem_mib: 0,
            time_minutes: 0,
        };
        for job in jobs {
            let e = Resources::estimate(&job.config, cmf_sim);
            r.cpus_per_task = r.cpus_per_task.max(e.cpus_per_task);
            r.mem_mib = r.mem_mib.max(e.mem_mib);
            r.time_minutes = r.time_minutes.max(e.time_minutes);
        }
        Resources {
            cpus_per_task: given.cpus_per_task.unwrap_or(r.cpus_per_task),
            mem_mib: given.mem_mib.unwrap_or(r.mem_mib),
            time_minutes: given.time_minutes.unwrap_or(r.time_minutes),
        }
    }
}

/// Quotes `s` for bash (single quotes).
fn quoted(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The script for `runs` tasks of the sweep folder `dir` (absolute), run by `exe`.
pub fn render(
    dir: &Path,
    exe: &Path,
    runs: usize,
    resources: &Resources,
    slurm: &SlurmSettings,
) -> String {
    let d = dir.display().to_string();
    let concurrency = slurm.concurrency.unwrap_or(DEFAULT_CONCURRENCY).min(runs);
    let r = resources;
    let mut s = String::from("#!/bin/bash\n");
    let mut line = |text: String| {
        s.push_str(&text);
        s.push('\n');
    };
    line("#SBATCH --job-name=colorvision-sweep".into());
    line(format!("#SBATCH --array=0-{}%{concurrency}", runs - 1));
    line(format!("#SBATCH --cpus-per-task={}", r.cpus_per_task));
    line(format!("#SBATCH --mem={}M", r.mem_mib));
    line(format!(
        "#SBATCH --time={:02}:{:02}:00",
        r.time_minutes / 60,
        r.time_minutes % 60
    ));
    line(format!("#SBATCH --output={d}/logs/task-%a.log"));
    line("#SBATCH --open-mode=append".into());
    line("#SBATCH --requeue".into());
    // SIGTERM a minute before the time limit: the run checkpoints and exits (code 130).
    line("#SBATCH --signal=B:TERM@60".into());
    if let Some(p) = &slurm.partition {
        line(format!("#SBATCH --partition={p}"));
    }
    if let Some(a) = &slurm.account {
        line(format!("#SBATCH --account={a}"));
    }
    let mut body = String::new();
    let _ = write!(
        body,
        r#"
# A colorvision sweep of {runs} runs, one array task each (see sweep.json for their settings).
# Submit: sbatch {d}/sweep.sbatch      Here: colorvision sweep --local -j N {d}
# A task whose run finished is skipped; an interrupted one resumes from its checkpoint, so
# the array may be requeued or submitted again. Results: colorvision gather {d}
set -euo pipefail
: "${{SLURM_ARRAY_TASK_ID:?is set by sbatch --array (or by hand, to run one task)}}"
if [ -z "${{COLORVISION:-}}" ]; then
    COLORVISION={exe}
fi
if [ -n "${{SLURM_CPUS_PER_TASK:-}}" ]; then
    export RAYON_NUM_THREADS="$SLURM_CPUS_PER_TASK"
fi
mkdir -p {dq}/logs
echo "colorvision sweep task $SLURM_ARRAY_TASK_ID on $(hostname) at $(date -u +%Y-%m-%dT%H:%M:%SZ)"
exec "$COLORVISION" sweep --task "$SLURM_ARRAY_TASK_ID" {dq}
"#,
        exe = quoted(&exe.display().to_string()),
        dq = quoted(&d),
    );
    s + &body
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_grows_with_steps_and_the_spec_overrides_it() {
        let mut c = RunConfig::preset("quick", "LMS").unwrap();
        let short = Resources::estimate(&c, true);
        c.steps *= 10;
        let long = Resources::estimate(&c, true);
        assert!(
            long.time_minutes > 5 * short.time_minutes,
            "{short:?} {long:?}"
        );
        assert_eq!(short.cpus_per_task, 2);
        // A paper-eye run of one step still asks for its end's 727 s, doubled.
        let mut paper = RunConfig::preset("paper", "LMS").unwrap();
        paper.steps = 1;
        assert!(Resources::estimate(&paper, false).time_minutes >= 2 * 727 / 60 + 5);
        let given = SlurmSettings {
            time_minutes: Some(7),
            ..SlurmSettings::default()
        };
        assert_eq!(Resources::for_jobs(&[], true, &given).time_minutes, 7);
    }

    #[test]
    fn the_script_asks_for_one_task_per_run_with_a_limit() {
        let r = Resources {
            cpus_per_task: 2,
            mem_mib: 2048,
            time_minutes: 125,
        };
        let slurm = SlurmSettings {
            concurrency: Some(3),
            partition: Some("cpu".into()),
            ..SlurmSettings::default()
        };
        let s = render(Path::new("/x/sw"), Path::new("/it's/cv"), 12, &r, &slurm);
        for want in [
            "#SBATCH --array=0-11%3\n",
            "#SBATCH --cpus-per-task=2\n",
            "#SBATCH --mem=2048M\n",
            "#SBATCH --time=02:05:00\n",
            "#SBATCH --partition=cpu\n",
            "#SBATCH --output=/x/sw/logs/task-%a.log\n",
            r#"    COLORVISION='/it'\''s/cv'"#,
            r#"sweep --task "$SLURM_ARRAY_TASK_ID" '/x/sw'"#,
        ] {
            assert!(s.contains(want), "{want} missing from\n{s}");
        }
        let one = render(
            Path::new("/x"),
            Path::new("/cv"),
            2,
            &r,
            &SlurmSettings::default(),
        );
        assert!(one.contains("--array=0-1%2\n"), "{one}");
    }
}
