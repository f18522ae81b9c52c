//! `hidden(eye, decoder, scenes=32)`: what a decoder's percept carries of each cone class's
//! *own* signal at the cones of the other classes, and which colour directions it carries — the
//! figures a run's `summary.json` holds under `invariants.recovery.hidden` and `.directions`
//! (`science::invariants::hidden`, `::directions`), for any decoder.
//!
//! The scenes are the run's held-out stream (`science::heldout::heldout_source`: its own scene
//! seed and batch seed, the same scenes on every call, never a training batch), frame 0 of
//! each; the first half fits, the second half scores; the sites are the cones inside the
//! loss border (`cortex.loss.border_px`). The truth (each cone's class and the excitations of
//! every class at it) is read on the Rust side for scoring only: the decoder sees the ONS.
//!
//! A Python decoder is called once on a black frame (its channel count and shape checked
//! before any scene is drawn) and then once per batch of
//! [`science::invariants::HIDDEN_BATCH_SIZE`] frames, on the calling thread; Rust works with
//! the GIL released ([`crate::beside`]).

use crate::beside::{decode_via, run_beside_python, PyDecoder};
use crate::decoders::{KnownDecoder, Run};
use crate::errors::science_error;
use crate::eye::Eye;
use crate::measure::probe_channels;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use science::config::RunConfig;
use science::invariants::{
    held_out_batches, measure_held_out_of, HELD_OUT_SCENES, HIDDEN_BATCH_SIZE,
};
use science::observer::oracle::ORACLE_PERCEPT_DIM;
use science::observer::{ObserverKind, OracleDecoder};
use science::source::RetinaSource;
use science::Error;
use std::sync::atomic::AtomicBool;

/// The percepts of `count` frames `(count, n, n)` into `(count, dim, n, n)`.
type Decode<'a> = Box<dyn FnMut(&[f32], usize) -> Result<Vec<f32>, String> + 'a>;

/// Most held-out scenes one call measures (each batch of four is kept until the end).
pub const MAX_SCENES: usize = 4096;

/// The run's held-out eye and its next `scenes` scenes (module docs), batch by batch until
/// `stop` is set.
fn held_out(
    config: &RunConfig,
    scenes: usize,
    stop: &AtomicBool,
) -> Result<(RetinaSource, Vec<retina::EyeBatch>), Error> {
    let mut source = science::heldout::heldout_source_until(config, true, stop)?;
    let mut batches = Vec::new();
    for _ in 0..scenes.div_ceil(HIDDEN_BATCH_SIZE) {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(Error::Stopped {
                stage: "the held-out scenes",
            });
        }
        batches.extend(held_out_batches(&mut source, HIDDEN_BATCH_SIZE));
    }
    Ok((source, batches))
}

/// The figures of `decode` (`dim` channels) on `batches` of `retina`, as JSON: `{"classes",
/// "unique_r2", "unique_share", "sites", "directions"}`.
fn measure(
    config: &RunConfig,
    (retina, batches): (&retina::Retina, &[retina::EyeBatch]),
    dim: usize,
    mut decode: Decode<'_>,
) -> Result<serde_json::Value, Error> {
    let mut failure = None;
    let (hidden, directions) = measure_held_out_of(
        retina,
        batches,
        dim,
        config.cortex.loss.border_px,
        |frames, count| match decode(frames, count) {
            Ok(p) => p,
            Err(why) => {
                failure.get_or_insert(why);
                vec![0.0; dim * frames.len()]
            }
        },
    );
    if let Some(why) = failure {
        return Err(Error::invalid("decoder", why));
    }
    let mut value = serde_json::to_value(&hidden).expect("figures serialise");
    value["directions"] = serde_json::to_value(&directions).expect("figures serialise");
    Ok(value)
}

/// A known-answer decoder on ONS frames, with its channel count: `identity` the frame itself,
/// `cones` its cone activations (the lateral inhibition inverted on the noisy frame, where
/// CMF-SIM's `cones` reads the noise-free activations), `oracle` / `oracle-mosaic` the oracle
/// of the eye's true mosaic on those activations (CMF-SIM's seed draws its embedding).
fn known<'r>(
    kind: ObserverKind,
    config: &RunConfig,
    eye: &'r retina::Retina,
) -> Result<(usize, Decode<'r>), Error> {
    let nn = eye.n() * eye.n();
    match kind {
        ObserverKind::Identity => Ok((1, Box::new(|frames: &[f32], _| Ok(frames.to_vec())))),
        ObserverKind::Cones => Ok((
            1,
            Box::new(move |frames: &[f32], _| {
                Ok(frames
                    .chunks_exact(nn)
                    .flat_map(|f| OracleDecoder::activations(eye, f, None))
                    .collect())
            }),
        )),
        ObserverKind::Oracle | ObserverKind::OracleMosaic => {
            let interpolate = kind == ObserverKind::Oracle;
            let oracle = science::measure::oracle_decoder(eye, config, interpolate)?;
            Ok((
                ORACLE_PERCEPT_DIM,
                Box::new(move |frames: &[f32], _| {
                    let mut out = vec![0f32; frames.len() / nn * ORACLE_PERCEPT_DIM * nn];
                    for (f, o) in frames
                        .chunks_exact(nn)
                        .zip(out.chunks_exact_mut(ORACLE_PERCEPT_DIM * nn))
                    {
                        oracle.decode(&OracleDecoder::activations(eye, f, None), o);
                    }
                    Ok(out)
                }),
            ))
        }
        other => Err(Error::invalid(
            "decoder",
            format!("`{}` has no percept of ONS frames", other.name()),
        )),
    }
}

/// What `decoder`'s percept carries of each cone class's own signal, and which colour
/// directions it carries (module docs), on `scenes` held-out scenes of `eye` (2 to
/// [`MAX_SCENES`], rounded up to whole batches of four). `decoder`: a
/// Python callable `(N, n, n)` → `(N, C, n, n)`, a known-answer decoder (`identity`, `cones`,
/// `oracle`, `oracle-mosaic`) or a trained run (`eye` must then be its eye).
#[pyfunction]
#[pyo3(signature = (eye, decoder, scenes=HELD_OUT_SCENES))]
pub fn hidden(
    py: Python<'_>,
    eye: &Bound<'_, Eye>,
    decoder: &Bound<'_, PyAny>,
    scenes: usize,
) -> PyResult<PyObject> {
    let eye = eye.get();
    if !(2..=MAX_SCENES).contains(&scenes) {
        return Err(PyValueError::new_err(format!(
            "scenes must be 2 to {MAX_SCENES} (half of them fit, half score), not {scenes}"
        )));
    }
    let config = &eye.config;
    let value = if let Ok(known_decoder) = decoder.downcast::<KnownDecoder>() {
        let kind = known_decoder.get().kind;
        run_beside_python(py, None, None, |_, stop| {
            let (source, batches) = held_out(config, scenes, stop)?;
            let (dim, decode) = known(kind, config, &source.retina)?;
            measure(config, (&source.retina, &batches), dim, decode)
        })?
    } else if let Ok(run) = decoder.downcast::<Run>() {
        let run = run.get();
        if run.config.retina != config.retina {
            return Err(PyValueError::new_err(
                "the eye is not the run's (its retina settings differ): pass `run.eye`",
            ));
        }
        let cortex = &run.cortex;
        run_beside_python(py, None, None, |_, stop| {
            let (source, batches) = held_out(&run.config, scenes, stop)?;
            let decode: Decode = Box::new(|frames, count| Ok(cortex.decode_frames(frames, count)));
            measure(
                &run.config,
                (&source.retina, &batches),
                cortex.percept_dim(),
                decode,
            )
        })?
    } else if decoder.is_callable() {
        let n = eye.discs.n();
        let channels = probe_channels(py, decoder, n)?;
        let py_decoder = PyDecoder {
            callable: decoder,
            channels,
            n,
        };
        run_beside_python(py, Some(&py_decoder), None, |tx, stop| {
            let (source, batches) = held_out(config, scenes, stop)?;
            let decode: Decode = Box::new(move |frames, count| {
                let mut out = vec![0f32; count * channels * n * n];
                decode_via(&tx, frames, count, &mut out).map(|()| out)
            });
            measure(config, (&source.retina, &batches), channels, decode)
        })?
    } else {
        return Err(PyTypeError::new_err(format!(
            "decoder: a {} is not callable; give a function (N, n, n) → (N, C, n, n), a \
             KnownDecoder or a Run",
            crate::arrays::type_name(decoder)
        )));
    };
    let value = value.map_err(science_error)?;
    let json = py.import("json")?;
    Ok(json.call_method1("loads", (value.to_string(),))?.unbind())
}
