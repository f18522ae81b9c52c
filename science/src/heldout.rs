//! Held-out evaluation of a cortex: a held-out eye (the run's mosaic and layout, other scenes)
//! and its batches, the same sequence on every call, and the prediction and motion errors a run
//! reports on them. Evaluation only: with `true_motion` the batches carry the eye's motion, which
//! the errors compare against; nothing here feeds learning.

use crate::config::RunConfig;
use crate::source::RetinaSource;
use crate::Error;
use cortex::{DataSource, Trainer};
use retina::Retina;
use std::sync::atomic::{AtomicBool, Ordering};

/// A held-out eye: the same mosaic and layout, different scenes (drawn until `stop` is set).
fn heldout_retina(config: &RunConfig, stop: &AtomicBool) -> Result<Retina, Error> {
    let mut c = config.retina.clone();
    c.scene_seed = c.scene_seed.wrapping_add(0x005E_ED0F_0E1D);
    Ok(Retina::with_progress_until(c, &|_| {}, stop)?)
}

/// The run's held-out batches (the held-out eye, its own batch seed), the same sequence on
/// every call; with `true_motion` each batch carries the eye's motion for evaluation.
pub fn heldout_source(config: &RunConfig, true_motion: bool) -> Result<RetinaSource, Error> {
    heldout_source_until(config, true_motion, &AtomicBool::new(false))
}

/// [`heldout_source`] whose scene drawing ends with [`Error::Stopped`] once `stop` is set.
pub fn heldout_source_until(
    config: &RunConfig,
    true_motion: bool,
    stop: &AtomicBool,
) -> Result<RetinaSource, Error> {
    Ok(RetinaSource::new(
        heldout_retina(config, stop)?,
        config.seed ^ 0xA5A5,
        true_motion,
    ))
}

/// The held-out stream of the hidden-signal measures ([`crate::invariants::measure_held_out`],
/// the own image): [`heldout_source`]'s eye and seeds, but its scene pool holds
/// [`HIDDEN_POOL_TILES`] tiles and replaces one after every batch, so `k` batches see about
/// `k + 3` different tiles and the scoring half shares at most three tiles with the fitting
/// half. A pool of a few tiles reused over many batches (the training pool's 32) makes the
/// figures those of a few scenes: on 32 scenes of it a kept quick cortex's S figure read −2.42,
/// on 1 024 of this stream 0.55 (docs/notebook/2026-12-05-hidden-signal-convergence.md).
pub fn hidden_source(config: &RunConfig) -> Result<RetinaSource, Error> {
    hidden_source_until(config, &AtomicBool::new(false))
}

/// [`hidden_source`] whose scene drawing ends with [`Error::Stopped`] once `stop` is set.
pub fn hidden_source_until(config: &RunConfig, stop: &AtomicBool) -> Result<RetinaSource, Error> {
    let mut fresh = config.clone();
    fresh.retina.scenes.tiles = HIDDEN_POOL_TILES;
    fresh.retina.scenes.refresh_every_batches = 1;
    heldout_source_until(&fresh, true, stop)
}

/// Tiles in the pool of [`hidden_source`]: one batch of the hidden measures
/// ([`crate::invariants::HIDDEN_BATCH_SIZE`]).
pub const HIDDEN_POOL_TILES: usize = crate::invariants::HIDDEN_BATCH_SIZE;

/// [`Error::Stopped`] once `stop` is set.
fn stopped(stop: &AtomicBool) -> Result<(), Error> {
    if stop.load(Ordering::Relaxed) {
        return Err(Error::Stopped {
            stage: "the held-out evaluation",
        });
    }
    Ok(())
}

/// Held-out prediction error `[model MSE, next = current MSE, ratio]` over `batches` batches
/// (ends with [`Error::Stopped`] once `stop` is set, checked before every batch).
pub fn heldout_error(
    trainer: &mut Trainer,
    heldout: &mut RetinaSource,
    bs: usize,
    batches: usize,
    stop: &AtomicBool,
) -> Result<[f64; 3], Error> {
    let (mut model, mut identity) = (0.0, 0.0);
    for _ in 0..batches.max(1) {
        stopped(stop)?;
        let b = heldout.next_batch(bs);
        let e = trainer.prediction_error(&b)?;
        model += e.model_mse;
        identity += e.identity_mse;
    }
    Ok([model, identity, identity / model.max(1e-30)])
}

/// Mean distance (ONS pixels) of the cortex's motion estimate from the true motion over
/// `batches` held-out batches (evaluation: the batches carry the oracle motion); ends with
/// [`Error::Stopped`] once `stop` is set.
pub fn heldout_motion_error(
    trainer: &mut Trainer,
    heldout: &mut RetinaSource,
    bs: usize,
    batches: usize,
    stop: &AtomicBool,
) -> Result<f64, Error> {
    let mut total = 0.0;
    for _ in 0..batches.max(1) {
        stopped(stop)?;
        let b = heldout.next_batch(bs);
        if let Some(e) = trainer.motion_error_ons_px(&b)? {
            total += e.mean_px;
        }
    }
    Ok(total / batches.max(1) as f64)
}
