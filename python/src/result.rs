//! `CmfSimResult`: CMF-SIM's answer as a plain Python object — the dimension, every K's
//! margin, the curves — and its JSON exactly as `colorvision cmf-sim` writes it.

use crate::arrays::f64_array;
use crate::errors::value_error;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The result of `cmf_sim` (fields in `docs/python.md`).
#[pyclass(module = "colorvision._native", frozen)]
pub struct CmfSimResult {
    pub(crate) inner: colorimetry::CmfSimResult,
}

impl CmfSimResult {
    fn json_value<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.call_method1("loads", (text,))
    }
}

#[pymethods]
impl CmfSimResult {
    /// The colour dimensionality: the first K whose primary set passes; 0 when undefined (no
    /// colour constancy, or no K up to the budget's largest passed).
    #[getter]
    fn dimension(&self) -> usize {
        self.inner.dimension
    }

    /// The verdict in words.
    #[getter]
    fn verdict(&self) -> &str {
        &self.inner.verdict
    }

    /// True when the base errors exceed the percept energy (dimension undefined).
    #[getter]
    fn no_colour_constancy(&self) -> bool {
        self.inner.no_colour_constancy
    }

    /// The observer measured, in words.
    #[getter]
    fn observer(&self) -> &str {
        &self.inner.observer
    }

    /// Every K tried → its converged margin: the worst error over the wavelengths as a
    /// multiple of the pass threshold (< 1 passes), of the passing set or of the best failing.
    #[getter]
    fn margins<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for k in &self.inner.per_k {
            d.set_item(k.n_primaries, k.converged_worst_ratio)?;
        }
        Ok(d)
    }

    /// Σ base error / Σ percept energy (≥ 1: no colour constancy).
    #[getter]
    fn base_over_energy(&self) -> f64 {
        let r = &self.inner;
        r.base_error.iter().sum::<f64>() / r.energy.iter().sum::<f64>().max(f64::MIN_POSITIVE)
    }

    /// The test wavelengths, nm.
    #[getter]
    fn test_wavelengths_nm<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        f64_array(py, self.inner.test_wavelengths_nm.clone())
    }

    /// Base error per test wavelength (the same light at two locations).
    #[getter]
    fn base_error<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        f64_array(py, self.inner.base_error.clone())
    }

    /// Percept energy per test wavelength (the 0-primary error).
    #[getter]
    fn energy<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        f64_array(py, self.inner.energy.clone())
    }

    /// Pass threshold per test wavelength.
    #[getter]
    fn threshold<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        f64_array(py, self.inner.threshold.clone())
    }

    /// The error curves, one dict per K from 0 (the energy): `n_primaries`, `primaries_nm`,
    /// `errors` (per test wavelength), `alphas`, `area`, `worst_ratio`, `passed`, `set_index`,
    /// `fully_evaluated`.
    #[getter]
    fn curves<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.inner.curves).map_err(value_error)?;
        Self::json_value(py, &text)
    }

    /// Wall time of the measurement, s.
    #[getter]
    fn seconds(&self) -> f64 {
        self.inner.seconds
    }

    /// Shows (stimulus presentations) the measurement made.
    #[getter]
    fn shows(&self) -> usize {
        self.inner.shows
    }

    /// The result as `cmf_sim.json` holds it (a str).
    fn json(&self) -> String {
        self.inner.to_json()
    }

    /// The result as a dict (`json.loads(self.json())`).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Self::json_value(py, &self.inner.to_json())
    }

    /// Writes `cmf_sim.json` and `cmf_sim_errors.svg` into `folder` (created if missing, each
    /// file written atomically); returns their paths.
    fn save(&self, py: Python<'_>, folder: PathBuf) -> PyResult<Vec<PathBuf>> {
        py.allow_threads(|| self.inner.save(&folder))
            .map_err(|e| value_error(format!("{}: {e}", folder.display())))
    }

    /// The lines `colorvision cmf-sim` prints: the verdict, the base error against the
    /// energy, each K's margin in words.
    fn summary(&self) -> String {
        colorvision::commands::cmf_sim_lines(&self.inner).join("\n")
    }

    fn __str__(&self) -> String {
        self.summary()
    }

    fn __repr__(&self) -> String {
        format!(
            "CmfSimResult(dimension={}, verdict={:?})",
            self.inner.dimension, self.inner.verdict
        )
    }
}
