//! The eye built with a progress bar over the scene files it prepares (`[retina.scenes] files`:
//! each file read, projected onto the eye's cone classes, resized and cached once; see
//! `retina::scene::prepared`). Synthetic scenes show no bar.

use std::sync::atomic::{AtomicUsize, Ordering};

use indicatif::{ProgressBar, ProgressStyle};
use retina::scene::pool::SceneProgress;
use retina::{Retina, RetinaConfig, RetinaError};

/// [`Retina::new`] (stopped by a stop request, [`crate::interrupt::stop_flag`]), drawing a bar on standard error while scene files are prepared, then one
/// line: how many files, how many from the cache.
pub fn retina(config: RetinaConfig) -> Result<Retina, RetinaError> {
    let stop = crate::interrupt::stop_flag();
    if config.scenes.files.is_empty() {
        return Retina::with_progress_until(config, &|_| {}, stop);
    }
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("  scenes {elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    let cached = AtomicUsize::new(0);
    let total = AtomicUsize::new(0);
    let report = |p: &SceneProgress<'_>| {
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
        bar.set_message(
            p.path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        );
        total.store(p.total, Ordering::Relaxed);
        if p.from_cache {
            cached.fetch_add(1, Ordering::Relaxed);
        }
    };
    let retina = Retina::with_progress_until(config, &report, stop);
    bar.finish_and_clear();
    let retina = retina?;
    let total = total.load(Ordering::Relaxed);
    println!(
        "  scenes: {total} {} prepared for this eye ({} from the cache in {})",
        if total == 1 { "file" } else { "files" },
        cached.load(Ordering::Relaxed),
        retina
            .config
            .scenes
            .cache_dir
            .clone()
            .or_else(|| retina::scene::plane_cache::default_dir().ok())
            .unwrap_or_default()
            .display()
    );
    Ok(retina)
}
