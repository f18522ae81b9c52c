//! Measures of a decoder on the run's held-out scenes, from Python: `hidden(eye, decoder,
//! scenes=None)`, what its percept carries of each cone class's *own* signal at the cones of the
//! other classes and which colour directions it carries — the figures a run's `summary.json`
//! holds under `invariants.recovery.hidden` and `.directions` (`science::invariants::hidden`,
//! `::directions`) — and `own_image(eye, decoder, scenes=None)`, the eye's last class's own
//! signal as a picture beside the percept's reading of it (`science::invariants::own_image`,
//! the run's `pictures/own_<class>.png`), for any decoder.
//!
//! The scenes are the hidden measures' held-out stream (`science::heldout::hidden_source`: the
//! held-out eye's scene seed and batch seed, the same scenes on every call, never a training
//! batch, a fresh scene tile every batch), frame 0 of each; by default
//! [`HELD_OUT_SCENES`] (1 024, converged; a run's summary reads `schedule.held_out_scenes`,
//! 32); the first half fits, the second half scores;
//! the sites are the cones inside the loss border (`cortex.loss.border_px`; every second or
//! fourth on an eye larger than 64 × 64 cones). The truth (each cone's class and the excitations of
//! every class at it) is read on the Rust side for scoring only: the decoder sees the ONS.
//!
//! A Python decoder is called once on a black frame (its channel count and shape checked
//! before any scene is drawn) and then once per batch of
//! [`science::invariants::HIDDEN_BATCH_SIZE`] frames, on the calling thread; Rust works with
//! the GIL released ([`crate::beside`]).

use crate::arrays::{f32_array, f64_array};
use crate::beside::{decode_via, run_beside_python, PyDecoder};
use crate::decoders::{choose, Chosen};
use crate::errors::science_error;
use crate::eye::Eye;
use crate::measure::probe_channels;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use science::config::RunConfig;
use science::invariants::own_image::{held_out_of as own_image_of, OwnImagePicture};
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

/// Most held-out scenes one call measures (each batch of four is kept until the end; an own
/// image also draws, and drops, the hidden measure's scenes before them).
pub const MAX_SCENES: usize = 4096;

/// The run's held-out eye and the `scenes` scenes `what` reads (module docs), batch by batch
/// until `stop` is set: the stream's first for [`Measure::Hidden`]; for [`Measure::OwnImage`]
/// those after the first `schedule.held_out_scenes`, the scenes a run's hidden measure reads
/// (as a run's pictures draw them: its own image then reads the next as many).
fn held_out(
    config: &RunConfig,
    scenes: usize,
    what: Measure,
    stop: &AtomicBool,
) -> Result<(RetinaSource, Vec<retina::EyeBatch>), Error> {
    let mut source = science::heldout::hidden_source_until(config, stop)?;
    let per = scenes.div_ceil(HIDDEN_BATCH_SIZE);
    let skip = match what {
        Measure::Hidden => 0,
        Measure::OwnImage => config.schedule.held_out_scenes.div_ceil(HIDDEN_BATCH_SIZE),
    };
    let mut batches = Vec::new();
    for b in 0..skip + per {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(Error::Stopped {
                stage: "the held-out scenes",
            });
        }
        if b < skip {
            // drawn to advance the stream, not kept (no copy)
            source.next_eye_batch(HIDDEN_BATCH_SIZE);
        } else {
            batches.extend(held_out_batches(&mut source, HIDDEN_BATCH_SIZE));
        }
    }
    Ok((source, batches))
}

/// `body` with `decode` as an infallible decode (zeros after its first error), then that error.
fn decoding<T>(
    mut decode: Decode<'_>,
    dim: usize,
    body: impl FnOnce(&mut dyn FnMut(&[f32], usize) -> Vec<f32>) -> T,
) -> Result<T, Error> {
    let mut failure = None;
    let out = body(&mut |frames, count| match decode(frames, count) {
        Ok(p) => p,
        Err(why) => {
            failure.get_or_insert(why);
            vec![0.0; dim * frames.len()]
        }
    });
    match failure {
        Some(why) => Err(Error::invalid("decoder", why)),
        None => Ok(out),
    }
}

/// What one call measures on the held-out scenes with the decoder.
#[derive(Clone, Copy)]
enum Measure {
    /// [`hidden`]: the figures as JSON.
    Hidden,
    /// [`own_image`]: the picture of the last class's own signal.
    OwnImage,
}

/// A measure's answer, made on the Rust side and turned into Python objects on the caller's.
enum Answer {
    Hidden(serde_json::Value),
    OwnImage(Option<OwnImagePicture>),
}

/// `what` of `decode` (`dim` channels) on `batches` of `retina`.
fn measure(
    config: &RunConfig,
    (retina, batches): (&retina::Retina, &[retina::EyeBatch]),
    (dim, decode): (usize, Decode<'_>),
    what: Measure,
) -> Result<Answer, Error> {
    let border = config.cortex.loss.border_px;
    match what {
        Measure::Hidden => {
            let (hidden, directions) = decoding(decode, dim, |d| {
                measure_held_out_of(retina, batches, dim, border, d)
            })?;
            let mut value = serde_json::to_value(&hidden).expect("figures serialise");
            value["directions"] = serde_json::to_value(&directions).expect("figures serialise");
            Ok(Answer::Hidden(value))
        }
        Measure::OwnImage => decoding(decode, dim, |d| {
            Answer::OwnImage(own_image_of(retina, batches, dim, border, d))
        }),
    }
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

/// `what` of `decoder` on `scenes` held-out scenes of `eye` (module docs): the decoder
/// resolved (a known-answer one, a run, a Python callable) and measured beside Python.
fn measured(
    py: Python<'_>,
    eye: &Eye,
    decoder: &Bound<'_, PyAny>,
    scenes: Option<usize>,
    what: Measure,
) -> PyResult<Answer> {
    let scenes = scenes.unwrap_or(HELD_OUT_SCENES);
    if !(2..=MAX_SCENES).contains(&scenes) {
        return Err(PyValueError::new_err(format!(
            "scenes must be 2 to {MAX_SCENES} (half of them fit, half score), not {scenes}"
        )));
    }
    let config = &eye.config;
    let chosen = choose(eye, decoder)?;
    if matches!(what, Measure::OwnImage) && eye.discs.mosaic.n_classes() < 2 {
        return Ok(Answer::OwnImage(None));
    }
    let answer = match chosen {
        Chosen::Known(kind) => run_beside_python(py, None, None, |_, stop| {
            let (source, batches) = held_out(config, scenes, what, stop)?;
            let decode = known(kind, config, &source.retina)?;
            measure(config, (&source.retina, &batches), decode, what)
        })?,
        Chosen::Run(run) => {
            let cortex = &run.cortex;
            run_beside_python(py, None, None, |_, stop| {
                let (source, batches) = held_out(&run.config, scenes, what, stop)?;
                let decode: Decode =
                    Box::new(|frames, count| Ok(cortex.decode_frames(frames, count)));
                let given = (cortex.percept_dim(), decode);
                measure(&run.config, (&source.retina, &batches), given, what)
            })?
        }
        Chosen::Python(callable) => {
            let n = eye.discs.n();
            let channels = probe_channels(py, callable, n)?;
            let py_decoder = PyDecoder {
                callable,
                channels,
                n,
            };
            run_beside_python(py, Some(&py_decoder), None, |tx, stop| {
                let (source, batches) = held_out(config, scenes, what, stop)?;
                let decode: Decode = Box::new(move |frames, count| {
                    let mut out = vec![0f32; count * channels * n * n];
                    decode_via(&tx, frames, count, &mut out).map(|()| out)
                });
                measure(config, (&source.retina, &batches), (channels, decode), what)
            })?
        }
    };
    answer.map_err(science_error)
}

/// What `decoder`'s percept carries of each cone class's own signal, and which colour
/// directions it carries (module docs), on `scenes` held-out scenes of `eye` (2 to
/// [`MAX_SCENES`], rounded up to whole batches of four), as a dict: `classes`, `unique_r2`,
/// `unique_share`, `sites`, `directions`. `decoder`: a Python callable `(N, n, n)` →
/// `(N, C, n, n)`, a known-answer decoder (`identity`, `cones`, `oracle`, `oracle-mosaic`) or
/// a trained run (`eye` must then be its eye).
#[pyfunction]
#[pyo3(signature = (eye, decoder, scenes=None))]
pub fn hidden(
    py: Python<'_>,
    eye: &Bound<'_, Eye>,
    decoder: &Bound<'_, PyAny>,
    scenes: Option<usize>,
) -> PyResult<PyObject> {
    let Answer::Hidden(value) = measured(py, eye.get(), decoder, scenes, Measure::Hidden)? else {
        unreachable!("a hidden measure answers with its figures")
    };
    let json = py.import("json")?;
    Ok(json.call_method1("loads", (value.to_string(),))?.unbind())
}

/// The eye's last class's own signal (what it catches beyond the other classes) on the last
/// held-out scene, beside `decoder`'s reading of it (module docs), on the `scenes` held-out
/// scenes (2 to [`MAX_SCENES`], rounded up to whole batches of four) after the
/// `schedule.held_out_scenes` that a run's summary reads, as a run's pictures draw them (so at
/// that count, 32, a run's `held_out_r2` is its `summary.json`'s). A dict: `class`,
/// `held_out_r2` (over the scoring half of the scenes), `truth` and `reading` `(side, side)`
/// float64 over the cones inside the loss border, `scene_srgb` `(3, n, n)` float32 (linear
/// sRGB at each cone), `class_range` (the class's excitation range over the last scene: the
/// scale its own signal is small against), `n`, `border`; `None` for an eye of one class.
#[pyfunction]
#[pyo3(signature = (eye, decoder, scenes=None))]
pub fn own_image(
    py: Python<'_>,
    eye: &Bound<'_, Eye>,
    decoder: &Bound<'_, PyAny>,
    scenes: Option<usize>,
) -> PyResult<PyObject> {
    let Answer::OwnImage(picture) = measured(py, eye.get(), decoder, scenes, Measure::OwnImage)?
    else {
        unreachable!("an own-image measure answers with its picture")
    };
    let Some(p) = picture else {
        return Ok(py.None());
    };
    let side = p.n - 2 * p.border;
    let d = PyDict::new(py);
    d.set_item("class", p.class)?;
    d.set_item("held_out_r2", p.held_out_r2)?;
    d.set_item("n", p.n)?;
    d.set_item("border", p.border)?;
    d.set_item("class_range", p.class_range)?;
    d.set_item(
        "truth",
        f64_array(py, p.truth).call_method1("reshape", ((side, side),))?,
    )?;
    d.set_item(
        "reading",
        f64_array(py, p.reading).call_method1("reshape", ((side, side),))?,
    )?;
    d.set_item("scene_srgb", f32_array(py, p.scene_srgb, &[3, p.n, p.n])?)?;
    Ok(d.into_any().unbind())
}
