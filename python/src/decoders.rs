//! Decoders CMF-SIM can measure from Python besides a Python callable: the known-answer
//! decoders of the calibration ladder (`science::ladder`) and a trained run's cortex.

use crate::arrays::{f32_array, read_f32, shape_text};
use crate::errors::run_error;
use crate::eye::Eye;
use autodiff::Tape;
use cortex::Cortex;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use science::config::RunConfig;
use science::observer::ObserverKind;
use std::path::PathBuf;

/// The names `KnownDecoder` takes, in the command line's words (`--observer`).
pub const KNOWN: [ObserverKind; 4] = [
    ObserverKind::Identity,
    ObserverKind::Cones,
    ObserverKind::Oracle,
    ObserverKind::OracleMosaic,
];

/// A decoder whose colour dimension is known (`colorvision cmf-sim --observer NAME`):
/// `identity` (the percept is the ONS: no colour constancy), `cones` (the cone activations
/// before lateral inhibition: 1), `oracle` (each kind of cone interpolated across the mosaic:
/// as many as independent kinds), `oracle-mosaic` (the oracle without interpolation).
#[pyclass(module = "colorvision._native", frozen)]
pub struct KnownDecoder {
    pub(crate) kind: ObserverKind,
}

#[pymethods]
impl KnownDecoder {
    #[new]
    fn new(name: &str) -> PyResult<Self> {
        KNOWN
            .into_iter()
            .find(|k| k.name() == name)
            .map(|kind| KnownDecoder { kind })
            .ok_or_else(|| {
                let names: Vec<&str> = KNOWN.iter().map(|k| k.name()).collect();
                PyValueError::new_err(format!(
                    "decoder `{name}` is not one of {}",
                    names.join(", ")
                ))
            })
    }

    /// Its name (`oracle`).
    #[getter]
    fn name(&self) -> &'static str {
        self.kind.name()
    }

    fn __repr__(&self) -> String {
        format!("KnownDecoder({:?})", self.kind.name())
    }
}

/// A measure's `decoder` argument, resolved and checked against the eye before any work.
pub enum Chosen<'a, 'py> {
    /// A known-answer decoder.
    Known(ObserverKind),
    /// A trained run, whose eye is the measured one.
    Run(&'a Run),
    /// A Python callable `(N, n, n)` → `(N, C, n, n)`, not called yet (the measure probes its
    /// channel count C with [`crate::measure::probe_channels`] once its own checks pass).
    Python(&'a Bound<'py, PyAny>),
}

/// `decoder` as one of the decoders a measure of `eye` takes: a `KnownDecoder`, a `Run` of
/// this eye (its retina settings equal), or a callable (not called here). A clear error for
/// anything else.
pub fn choose<'a, 'py>(eye: &Eye, decoder: &'a Bound<'py, PyAny>) -> PyResult<Chosen<'a, 'py>> {
    if let Ok(known) = decoder.downcast::<KnownDecoder>() {
        Ok(Chosen::Known(known.get().kind))
    } else if let Ok(run) = decoder.downcast::<Run>() {
        let run = run.get();
        if run.config.retina != eye.config.retina {
            return Err(PyValueError::new_err(
                "the eye is not the run's (its retina settings differ): pass `run.eye`",
            ));
        }
        Ok(Chosen::Run(run))
    } else if decoder.is_callable() {
        Ok(Chosen::Python(decoder))
    } else {
        Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "decoder: a {} is not callable; give a function (N, n, n) → (N, C, n, n), a \
             KnownDecoder or a Run",
            crate::arrays::type_name(decoder)
        )))
    }
}

/// A trained run folder: its settings, its eye and its learned cortex as a decoder.
#[pyclass(module = "colorvision._native", frozen)]
pub struct Run {
    pub(crate) config: RunConfig,
    pub(crate) cortex: Cortex,
    checkpoint: PathBuf,
    eye: Py<Eye>,
}

/// Loads a run folder written by `colorvision run`/`train` (its newest valid checkpoint, or
/// that of `checkpoint_step`), checked as `colorvision cmf-sim --run DIR` checks it.
#[pyfunction]
#[pyo3(signature = (path, checkpoint_step=None))]
pub fn load_run(py: Python<'_>, path: PathBuf, checkpoint_step: Option<u64>) -> PyResult<Run> {
    let (config, cortex, checkpoint) = py
        .allow_threads(|| {
            colorvision::run::folder::load_run_step(&path, checkpoint_step)
                .map(|(config, trainer, checkpoint)| (config, trainer.cortex, checkpoint))
        })
        .map_err(run_error)?;
    let eye = Py::new(py, Eye::from_config(py, config.clone())?)?;
    Ok(Run {
        config,
        cortex,
        checkpoint,
        eye,
    })
}

#[pymethods]
impl Run {
    /// The run's eye (its settings; a model trained on it sees its batches).
    #[getter]
    fn eye(&self, py: Python<'_>) -> Py<Eye> {
        self.eye.clone_ref(py)
    }

    /// The checkpoint loaded.
    #[getter]
    fn checkpoint(&self) -> PathBuf {
        self.checkpoint.clone()
    }

    /// Channels C of the cortex's percept.
    #[getter]
    fn channels(&self) -> usize {
        self.cortex.percept_dim()
    }

    /// The run's settings as TOML (its `config.toml`).
    #[getter]
    fn config_toml(&self) -> String {
        self.config.to_toml()
    }

    /// The cortex's percepts `(N, C, n, n)` float32 of ONS frames `(N, n, n)`.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        ons: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let frames = read_f32(py, ons, "ons")?;
        let n = self.eye.get().discs.n();
        let [shows, a, b] = frames.shape[..] else {
            return Err(PyValueError::new_err(format!(
                "ons: shape {} is not (N, n, n) with n = {n}",
                shape_text(&frames.shape)
            )));
        };
        if a != n || b != n || shows == 0 {
            return Err(PyValueError::new_err(format!(
                "ons: shape {} is not (N, {n}, {n}) with N ≥ 1",
                shape_text(&frames.shape)
            )));
        }
        let cortex = &self.cortex;
        let percept = py.allow_threads(|| {
            let mut tape = Tape::default();
            let o = tape.constant_from([shows, 1, n, n], &frames.values);
            let v = cortex.record_decode(&mut tape, o).percept;
            tape.value(v).data().to_vec()
        });
        f32_array(py, percept, &[shows, self.cortex.percept_dim(), n, n])
    }

    fn __repr__(&self) -> String {
        format!(
            "Run(checkpoint={:?})",
            self.checkpoint.display().to_string()
        )
    }
}
