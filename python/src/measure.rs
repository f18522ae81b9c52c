//! `cmf_sim(eye, decoder, …)`: the calibrated CMF-SIM on a Python callable, a known-answer
//! decoder or a trained run, with the GIL released while Rust works ([`crate::beside`]).
//!
//! A Python decoder is first called once on one black frame `(1, n, n)` — its answer gives the
//! channel count C and shows any shape error before the measurement starts — then once per
//! batch of at most `batch_size` shows. It is a nonlinear observer: CMF-SIM shows it every
//! stimulus (`science::observer::ExternalDecoder`).

use crate::arrays::{read_f32, shape_text};
use crate::beside::{decode_via, run_beside_python, PyDecoder, Request};
use crate::decoders::{choose, Chosen};
use crate::errors::{science_error, value_error};
use crate::eye::Eye;
use crate::result::CmfSimResult;
use colorimetry::cmf_sim::CmfSimProgress;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use science::config::RunConfig;
use science::observer::{Decoder, ExternalDecoder, ObserverKind};
use std::sync::mpsc::Sender;

/// The settings of one measurement: the eye's (or the run's), with the budget and seed given.
fn measurement_config(
    mut config: RunConfig,
    budget: &str,
    location_seed: Option<u64>,
) -> PyResult<RunConfig> {
    config.cmf_sim = match budget {
        "full" => config.cmf_settings(true),
        "quick" => config.cmf_settings(false),
        other => {
            return Err(PyValueError::new_err(format!(
                "budget `{other}` is not one of full (the run's final measurement, as \
                 `colorvision cmf-sim`), quick (the smaller budget of measurements during \
                 training)"
            )))
        }
    };
    if let Some(seed) = location_seed {
        config.cmf_sim.seed = seed;
    }
    config.validate().map_err(value_error)?;
    Ok(config)
}

/// The progress report of one primary set, sent to the Python thread.
fn progress_sender(tx: &Sender<Request>) -> impl FnMut(&CmfSimProgress) + '_ {
    move |p: &CmfSimProgress| {
        let line = format!(
            "CMF-SIM K = {}: {} of {} sets tried, best worst ratio {:.3}",
            p.n_primaries, p.sets_tried, p.sets_per_k, p.best_worst_ratio
        );
        let figures = vec![
            ("n_primaries", p.n_primaries as f64),
            ("sets_tried", p.sets_tried as f64),
            ("sets_per_k", p.sets_per_k as f64),
            ("best_worst_ratio", p.best_worst_ratio),
        ];
        let _ = tx.send(Request::Progress { line, figures });
    }
}

/// The channel count C of a Python decoder, from its answer to one black frame.
pub(crate) fn probe_channels(
    py: Python<'_>,
    callable: &Bound<'_, PyAny>,
    n: usize,
) -> PyResult<usize> {
    let frames = crate::arrays::f32_array(py, vec![0f32; n * n], &[1, n, n])?;
    let out = callable.call1((frames,))?;
    let percepts = read_f32(py, &out, "the decoder's output")?;
    match percepts.shape[..] {
        [1, c, a, b] if c >= 1 && a == n && b == n => {
            crate::arrays::check_finite(
                &percepts.values,
                &percepts.shape,
                "the decoder's percept of a black frame",
            )?;
            Ok(c)
        }
        _ => Err(PyValueError::new_err(format!(
            "the decoder returned percepts of shape {} for ONS of shape (1, {n}, {n}); \
             expected (N, C, n, n) = (1, C, {n}, {n}) with C ≥ 1",
            shape_text(&percepts.shape)
        ))),
    }
}

/// The decoder's name in CMF-SIM's record: `Python decoder `qualname``.
fn python_name(callable: &Bound<'_, PyAny>) -> String {
    let name = callable
        .getattr("__qualname__")
        .or_else(|_| callable.get_type().getattr("__qualname__"))
        .and_then(|n| n.extract::<String>())
        .unwrap_or_else(|_| "?".into());
    format!("Python decoder `{name}`")
}

/// CMF-SIM of `eye` followed by `decoder` (module docs; `docs/python.md`).
///
/// `decoder`: a callable `(N, n, n)` float32 → `(N, C, n, n)`, a `KnownDecoder`, or a `Run`
/// (`load_run`; then `eye` must be the run's eye). `budget`: `"full"` (the final measurement
/// of a run, as `colorvision cmf-sim`) or `"quick"` (the budget of measurements during
/// training). `location_seed`: CMF-SIM's draws (locations, primaries), as `--location-seed`.
/// `batch_size`: most shows per decoder call. `progress`: called with a dict after every
/// primary set (default: the `colorvision` logger at INFO).
#[pyfunction]
#[pyo3(signature = (eye, decoder, budget="full", location_seed=None, batch_size=256, progress=None))]
pub fn cmf_sim(
    py: Python<'_>,
    eye: &Bound<'_, Eye>,
    decoder: &Bound<'_, PyAny>,
    budget: &str,
    location_seed: Option<u64>,
    batch_size: usize,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<CmfSimResult> {
    let eye = eye.get();
    if batch_size == 0 {
        return Err(PyValueError::new_err("batch_size must be ≥ 1"));
    }
    // The decoder's kind and eye first, then the settings (the budget's name among them), then
    // a Python decoder's probe.
    let result = match choose(eye, decoder)? {
        Chosen::Known(kind) => {
            let config = measurement_config(eye.config.clone(), budget, location_seed)?;
            run_beside_python(py, None, progress, |tx, stop| {
                science::measure::measure_observer_with(
                    &config,
                    kind,
                    None,
                    &mut progress_sender(&tx),
                    stop,
                )
            })?
        }
        Chosen::Run(run) => {
            let mut config = run.config.clone();
            config.observer = eye.config.observer.clone();
            config.cmf_sim = eye.config.cmf_sim.clone();
            config.schedule = eye.config.schedule.clone();
            let config = measurement_config(config, budget, location_seed)?;
            let cortex = &run.cortex;
            run_beside_python(py, None, progress, |tx, stop| {
                science::measure::measure_observer_with(
                    &config,
                    ObserverKind::Cortex,
                    Some(cortex),
                    &mut progress_sender(&tx),
                    stop,
                )
            })?
        }
        Chosen::Python(callable) => {
            let config = measurement_config(eye.config.clone(), budget, location_seed)?;
            let n = eye.discs.n();
            let channels = probe_channels(py, callable, n)?;
            let name = python_name(callable);
            let retina = &*eye.discs;
            let py_decoder = PyDecoder {
                callable,
                channels,
                n,
            };
            run_beside_python(py, Some(&py_decoder), progress, |tx, stop| {
                let sender = tx.clone();
                let batch = move |ons: &[f32], shows: usize, out: &mut [f32]| {
                    decode_via(&sender, ons, shows, out)
                };
                let external =
                    ExternalDecoder::new(name, channels, batch_size, stop, Box::new(batch));
                science::measure::measure_decoder_until(
                    retina,
                    Decoder::External(external),
                    &config,
                    &mut progress_sender(&tx),
                    stop,
                )
            })?
        }
    };
    result
        .map(|inner| CmfSimResult { inner })
        .map_err(science_error)
}
