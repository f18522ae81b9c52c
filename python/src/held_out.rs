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
//! 1 024, a `tiny` run 32); the first half fits, the second half scores;
//! the sites are the cones inside the loss border (`cortex.loss.border_px`), at most 16 × 16 of
//! them a scene (`science::invariants::hidden::MAX_SITES_PER_SAMPLE`). The truth (each cone's class and the excitations of
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
use science::invariants::own_image::{of_scenes as own_image_of, OwnImagePicture};
use science::invariants::{gather_held_out, measure_samples, HELD_OUT_SCENES, HIDDEN_BATCH_SIZE};
use science::observer::oracle::ORACLE_PERCEPT_DIM;
use science::observer::{ObserverKind, OracleDecoder};
use science::Error;
use std::sync::atomic::AtomicBool;

/// The percepts of `count` frames `(count, n, n)` into `(count, dim, n, n)`.
type Decode<'a> = Box<dyn FnMut(&[f32], usize) -> Result<Vec<f32>, String> + 'a>;

/// Most held-out scenes one call measures (each is read as it is drawn; the kept cones of every
/// scene stay until the figures are made).
pub const MAX_SCENES: usize = 4096;

/// [`Error::Stopped`] once `stop` is set.
fn stopped(stop: &AtomicBool) -> Result<(), Error> {
    match stop.load(std::sync::atomic::Ordering::Relaxed) {
        true => Err(Error::Stopped {
            stage: "the held-out scenes",
        }),
        false => Ok(()),
    }
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

/// `what` of `decode` (`dim` channels) on `scenes` scenes of the run's held-out stream (module
/// docs), drawn and read batch by batch until `stop` is set: the stream's first for
/// [`Measure::Hidden`]; for [`Measure::OwnImage`] those after the first
/// `schedule.held_out_scenes`, the scenes a run's hidden measure reads (as a run's pictures draw
/// them: its own image then reads the next as many).
fn measure(
    config: &RunConfig,
    scenes: usize,
    (dim, decode): (usize, Decode<'_>),
    what: Measure,
    stop: &AtomicBool,
) -> Result<Answer, Error> {
    let mut source = science::heldout::hidden_source_until(config, stop)?;
    if let Measure::OwnImage = what {
        for _ in 0..config.schedule.held_out_scenes.div_ceil(HIDDEN_BATCH_SIZE) {
            stopped(stop)?;
            source.skip_batches(1);
        }
    }
    let border = config.cortex.loss.border_px;
    let gathered = decoding(decode, dim, |d| {
        gather_held_out(&mut source, scenes, dim, border, d, || stopped(stop))
    })??;
    match what {
        Measure::Hidden => {
            let names = source.retina.mosaic.class_names();
            let (hidden, directions) = measure_samples(&gathered.samples, &names);
            let mut value = serde_json::to_value(&hidden).expect("figures serialise");
            value["directions"] = serde_json::to_value(&directions).expect("figures serialise");
            Ok(Answer::Hidden(value))
        }
        Measure::OwnImage => Ok(Answer::OwnImage(own_image_of(
            &source.retina,
            &gathered,
            border,
        ))),
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
            let decode = known(kind, config, &eye.discs)?;
            measure(config, scenes, decode, what, stop)
        })?,
        Chosen::Run(run) => {
            let cortex = &run.cortex;
            run_beside_python(py, None, None, |_, stop| {
                let decode: Decode =
                    Box::new(|frames, count| Ok(cortex.decode_frames(frames, count)));
                let given = (cortex.percept_dim(), decode);
                measure(&run.config, scenes, given, what, stop)
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
                let decode: Decode = Box::new(move |frames, count| {
                    let mut out = vec![0f32; count * channels * n * n];
                    decode_via(&tx, frames, count, &mut out).map(|()| out)
                });
                measure(config, scenes, (channels, decode), what, stop)
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
/// that count a run's `held_out_r2` is its `summary.json`'s). A dict: `class`,
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
