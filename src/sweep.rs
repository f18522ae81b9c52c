//! Sweeps: a grid of settings run as one folder per run, on a Slurm cluster or here.
//!
//! `colorvision sweep SPEC.toml --out DIR` expands the spec ([`spec`]) and writes, all at once
//! (nothing when any run's settings are wrong):
//! - `DIR/<index>_<key>=<value>…/config.toml` and `run.json`: each run folder, ready to start;
//! - `DIR/sweep.json` ([`task::Manifest`]): the runs in array-task order, with their settings;
//! - `DIR/sweep.toml`: the spec, copied;
//! - `DIR/sweep.sbatch` ([`script`]): the Slurm job array, one task per run;
//! - `DIR/logs/`: each task's output (`task-<index>.log`).
//!
//! `colorvision sweep --local -j N DIR` runs the same tasks here ([`local`]);
//! `colorvision sweep --task I DIR` is one task ([`task`]); `colorvision gather DIR` tabulates
//! the results ([`crate::gather`]).

pub mod local;
pub mod script;
pub mod spec;
pub mod task;

use crate::run::error::RunError;
use crate::run::RunMarker;
use clap::Args;
use std::path::{Path, PathBuf};

/// Options of `sweep`.
#[derive(Debug, Clone, Args)]
pub struct SweepOptions {
    /// A sweep spec (TOML) to expand into --out; with --local or --task, a sweep folder.
    pub path: PathBuf,
    /// The sweep folder to write (new or empty; default `runs/sweep-<spec name>`).
    #[arg(long, conflicts_with_all = ["local", "task"])]
    pub out: Option<PathBuf>,
    /// Run every task of the sweep folder PATH on this machine (skips finished runs, resumes
    /// interrupted ones).
    #[arg(long, conflicts_with = "task")]
    pub local: bool,
    /// With --local: tasks running at once.
    #[arg(short = 'j', long, default_value_t = 1, requires = "local")]
    pub jobs: usize,
    /// Run the one task of this index (what each Slurm array task does).
    #[arg(long)]
    pub task: Option<usize>,
}

/// `colorvision sweep`.
pub fn command(options: &SweepOptions) -> Result<(), RunError> {
    if options.local {
        return local::run_local(&options.path, options.jobs);
    }
    if let Some(index) = options.task {
        crate::interrupt::install().map_err(|e| RunError::Folder {
            path: options.path.clone(),
            reason: format!("cannot catch SIGINT/SIGTERM: {e}"),
        })?;
        return task::run_task(&options.path, index);
    }
    let out = options.out.clone().unwrap_or_else(|| {
        let stem = options
            .path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy();
        Path::new("runs").join(format!("sweep-{stem}"))
    });
    let manifest = write_sweep(&options.path, &out)?;
    println!(
        "colorvision sweep: {} runs in {} (grid: {})",
        manifest.tasks.len(),
        out.display(),
        manifest.keys.join(" × ")
    );
    let r = &manifest.resources;
    println!(
        "  each task asks for {} CPUs, {} MiB, {} min",
        r.cpus_per_task, r.mem_mib, r.time_minutes
    );
    println!("  on Slurm:  sbatch {}/sweep.sbatch", out.display());
    println!(
        "  here:      colorvision sweep --local -j 2 {}",
        out.display()
    );
    println!("  results:   colorvision gather {}", out.display());
    Ok(())
}

/// Expands the spec at `spec_path` into the sweep folder `out` (see the module docs).
pub fn write_sweep(spec_path: &Path, out: &Path) -> Result<task::Manifest, RunError> {
    let expanded = spec::expand(spec_path)?;
    let folder_error = |reason: &str| RunError::Folder {
        path: out.to_path_buf(),
        reason: format!("(--out) {reason}"),
    };
    if out.exists() && (!out.is_dir() || out.read_dir().map_or(true, |mut d| d.next().is_some())) {
        return Err(folder_error(
            "exists and is not an empty folder: choose another --out",
        ));
    }
    let dir = std::path::absolute(out).map_err(crate::io::fs_err(out))?;
    if dir
        .to_string_lossy()
        .contains(|c: char| c.is_whitespace() || matches!(c, '%' | '\'' | '"' | '\\' | '$' | '`'))
    {
        return Err(folder_error(
            "has a space, quote, `%`, `$` or backslash, which Slurm's #SBATCH lines cannot carry",
        ));
    }
    let spec_text = std::fs::read(spec_path).map_err(crate::io::fs_err(spec_path))?;
    let cmf_sim = expanded.command == "run";
    let resources = script::Resources::for_jobs(&expanded.jobs, cmf_sim, &expanded.slurm);
    let exe = std::env::current_exe().map_err(crate::io::fs_err(Path::new("/proc/self/exe")))?;
    let manifest = task::Manifest {
        spec: std::path::absolute(spec_path).unwrap_or_else(|_| spec_path.to_path_buf()),
        command: expanded.command.clone(),
        keys: expanded.axes.iter().map(|a| a.key.clone()).collect(),
        resources,
        tasks: expanded
            .jobs
            .iter()
            .map(|j| task::TaskEntry {
                folder: j.folder.clone(),
                settings: j
                    .settings
                    .iter()
                    .map(|(k, v)| (k.clone(), v.to_string()))
                    .collect(),
            })
            .collect(),
    };
    let marker = RunMarker {
        cmf_sim,
        pictures: true,
        continued_from: None,
    };
    let sbatch = script::render(&dir, &exe, expanded.jobs.len(), &resources, &expanded.slurm);
    crate::io::save_into(out, |staging| -> Result<(), RunError> {
        for job in &expanded.jobs {
            let run = staging.join(&job.folder);
            crate::io::write_atomic(&run.join("config.toml"), job.config.to_toml().as_bytes())?;
            crate::io::write_json(&run.join("run.json"), &marker)?;
        }
        crate::io::write_json(&staging.join(task::MANIFEST_FILE), &manifest)?;
        crate::io::write_atomic(&staging.join("sweep.toml"), &spec_text)?;
        crate::io::write_atomic(&staging.join("sweep.sbatch"), sbatch.as_bytes())?;
        Ok(())
    })?;
    // Slurm opens each task's log before the task runs: the folder must exist.
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).map_err(crate::io::fs_err(&logs))?;
    Ok(manifest)
}
