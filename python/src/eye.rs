//! `Eye`: the simulated eye from Python — settings as the command line resolves them, the ONS
//! of a scene cube or of the built-in scenes, training batches, and the truth kept apart.
//!
//! Two retinas of the same settings: one built at once without scenes (its mosaic, positions
//! and lateral inhibition are the eye's; CMF-SIM's disc stimuli and a user's scene need no
//! scene pool), and one with the scene pool, built on the first batch or built-in scene.

use crate::arrays::{f32_array, read_f32, shape_text};
use crate::beside::run_beside_python;
use crate::errors::{science_error, value_error};
use colorimetry::WavelengthGrid;
use cortex::OnsBatch;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use retina::scene::SpectralImage;
use retina::Retina;
use science::config::{Overrides, RunConfig};
use science::source::RetinaSource;
use std::sync::{Arc, Mutex};

/// The simulated eye (module docs; `colorvision.Eye` in `docs/python.md`).
#[pyclass(module = "colorvision._native", frozen)]
pub struct Eye {
    pub(crate) config: RunConfig,
    /// Built without scenes (`scenes.tiles = 1`): the mosaic, positions and LI of the eye.
    pub(crate) discs: Arc<Retina>,
    /// The eye with its scene pool, as training sees it; built on first use.
    source: Mutex<Option<RetinaSource>>,
}

impl Eye {
    /// The eye of resolved settings (its scene-free retina built at once, interruptibly).
    pub(crate) fn from_config(py: Python<'_>, config: RunConfig) -> PyResult<Eye> {
        config.validate().map_err(value_error)?;
        let mut eye = config.retina.clone();
        eye.scenes.tiles = 1;
        let discs = run_beside_python(py, None, None, |_, stop| {
            Retina::with_progress_until(eye, &|_| {}, stop)
        })?
        .map_err(|e| science_error(e.into()))?;
        Ok(Eye {
            config,
            discs: Arc::new(discs),
            source: Mutex::new(None),
        })
    }

    fn n(&self) -> usize {
        self.discs.n()
    }

    /// Runs `f` on the eye with its scene pool (built first if needed), GIL released.
    fn with_source<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut RetinaSource) -> T + Send,
    ) -> PyResult<T> {
        let built = self.source.lock().expect("eye lock").is_some();
        if !built {
            let config = self.config.retina.clone();
            let retina = run_beside_python(py, None, None, |_, stop| {
                Retina::with_progress_until(config, &|_| {}, stop)
            })?
            .map_err(|e| science_error(e.into()))?;
            let mut slot = self.source.lock().expect("eye lock");
            slot.get_or_insert_with(|| {
                RetinaSource::new(retina, self.config.seed, self.config.oracle_motion)
            });
        }
        Ok(py.allow_threads(|| {
            let mut slot = self.source.lock().expect("eye lock");
            f(slot.as_mut().expect("built above"))
        }))
    }

    fn batch_size(&self, batch_size: Option<usize>) -> PyResult<usize> {
        let b = batch_size.unwrap_or(self.config.cortex.train.batch_size);
        if b == 0 {
            return Err(PyValueError::new_err("batch_size must be ≥ 1"));
        }
        Ok(b)
    }

    /// The next batch: ONS at t `(B, n, n)`, at t + 1 `(B, n, n)`, the shift `(B, 2)`.
    fn draw<'py>(&self, py: Python<'py>, batch_size: usize) -> PyResult<Bound<'py, PyTuple>> {
        let (ons, shift) = self.with_source(py, |source| {
            let b = source.next_eye_batch(batch_size);
            let signal: &OnsBatch = &b.signal;
            let shift: Vec<f32> = b
                .truth
                .oracle_shift_normalised
                .iter()
                .flat_map(|d| [d[0], d[1]])
                .collect();
            (signal.ons.clone(), shift)
        })?;
        let nn = self.n() * self.n();
        let (mut t0, mut t1) = (Vec::with_capacity(batch_size * nn), Vec::new());
        t1.reserve(batch_size * nn);
        for pair in ons.chunks_exact(2 * nn) {
            t0.extend_from_slice(&pair[..nn]);
            t1.extend_from_slice(&pair[nn..]);
        }
        let shape = [batch_size, self.n(), self.n()];
        PyTuple::new(
            py,
            [
                f32_array(py, t0, &shape)?,
                f32_array(py, t1, &shape)?,
                f32_array(py, shift, &[batch_size, 2])?,
            ],
        )
    }
}

#[pymethods]
impl Eye {
    /// `Eye(preset="quick", cones="LMS", seed=0, settings=None, **more)`: the eye of a preset
    /// and cone types, with any setting of a run's `config.toml` given as `settings` (a dict of
    /// dotted keys, `{"observer.noise_ratio": 0.1}`) or as keywords (`steps=300`,
    /// `observer__noise_ratio=0.1`: `__` reads as `.`), resolved and validated exactly as
    /// `--preset/--cones/--seed/--set` are; a bad one raises `ValueError` with the command
    /// line's message.
    #[new]
    #[pyo3(signature = (preset="quick", cones="LMS", seed=0, settings=None, **more))]
    fn new(
        py: Python<'_>,
        preset: &str,
        cones: &str,
        seed: u64,
        settings: Option<&Bound<'_, PyDict>>,
        more: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mut set = Vec::new();
        for dict in settings.into_iter().chain(more) {
            for (k, v) in dict.iter() {
                set.push(crate::settings::setting(&k.extract::<String>()?, &v)?);
            }
        }
        let overrides = Overrides {
            preset: Some(preset.into()),
            cones: Some(cones.into()),
            seed: Some(seed),
            set,
            ..Overrides::default()
        };
        let config = RunConfig::resolve(&overrides, "quick").map_err(value_error)?;
        Eye::from_config(py, config)
    }

    /// Cones per side n (an ONS frame is `(n, n)`).
    #[getter]
    fn n_cones(&self) -> usize {
        self.n()
    }

    /// Side of the scene field the cones sample, px.
    #[getter]
    fn field_px(&self) -> usize {
        self.config.retina.field_px
    }

    /// The eye's wavelength grid, nm (a scene cube is resampled onto it).
    #[getter]
    fn wavelengths_nm<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        crate::arrays::f64_array(py, self.discs.grid().as_slice().to_vec())
    }

    /// The preset the settings started from.
    #[getter]
    fn preset(&self) -> &str {
        &self.config.preset
    }

    /// The cone types (`--cones`).
    #[getter]
    fn cones(&self) -> &str {
        &self.config.cones
    }

    /// The seed of every random draw.
    #[getter]
    fn seed(&self) -> u64 {
        self.config.seed
    }

    /// The batch size of the preset's training (the default of `batch` and `batches`).
    #[getter]
    fn batch_size_default(&self) -> usize {
        self.config.cortex.train.batch_size
    }

    /// Every resolved setting as TOML (a run's `config.toml`).
    #[getter]
    fn config_toml(&self) -> String {
        self.config.to_toml()
    }

    /// The noise-free ONS `(n, n)` float32 of a scene cube `(H, W, L)` (radiance, finite and
    /// ≥ 0) sampled at `wavelengths_nm` `(L,)` (increasing, covering the eye's grid). The
    /// field's top-left is the cube's top-left pixel; H and W must be at least `field_px`.
    fn ons<'py>(
        &self,
        py: Python<'py>,
        scene: &Bound<'py, PyAny>,
        wavelengths_nm: Vec<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let cube = read_f32(py, scene, "scene")?;
        let f = self.field_px();
        let [h, w, l] = cube.shape[..] else {
            return Err(PyValueError::new_err(format!(
                "scene: shape {} is not (H, W, wavelengths)",
                shape_text(&cube.shape)
            )));
        };
        if l != wavelengths_nm.len() || h < f || w < f {
            return Err(PyValueError::new_err(format!(
                "scene: shape {} needs H, W ≥ field_px = {f} and {} wavelengths (one per \
                 wavelengths_nm)",
                shape_text(&cube.shape),
                wavelengths_nm.len()
            )));
        }
        let grid = WavelengthGrid::new(wavelengths_nm)
            .map_err(|e| value_error(format!("wavelengths_nm: {e}")))?;
        let mut data = vec![0f32; l * h * w];
        for (p, spectrum) in cube.values.chunks_exact(l).enumerate() {
            for (k, v) in spectrum.iter().enumerate() {
                data[k * h * w + p] = *v;
            }
        }
        let image = SpectralImage { grid, h, w, data };
        image
            .check_radiance(std::path::Path::new("scene"))
            .map_err(|e| science_error(e.into()))?;
        let retina = self.discs.clone();
        let ons = py
            .allow_threads(move || retina.encode_spectral(&image))
            .map_err(|e| science_error(e.into()))?;
        f32_array(py, ons, &[self.n(), self.n()])
    }

    /// The noise-free ONS `(n, n)` float32 of built-in scene tile `tile` (the scenes training
    /// draws from), the field's top-left at `origin_px = (x, y)` in the tile (default: centred).
    #[pyo3(signature = (tile=0, origin_px=None))]
    fn scene_ons<'py>(
        &self,
        py: Python<'py>,
        tile: usize,
        origin_px: Option<(i32, i32)>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (f, tile_px) = (
            self.config.retina.field_px as i32,
            self.config.retina.scenes.tile_px as i32,
        );
        let tiles = self.config.retina.scenes.tiles;
        let (x, y) = origin_px.unwrap_or(((tile_px - f) / 2, (tile_px - f) / 2));
        if tile >= tiles || !(0..=tile_px - f).contains(&x) || !(0..=tile_px - f).contains(&y) {
            return Err(PyValueError::new_err(format!(
                "scene_ons: tile {tile} at origin ({x}, {y}): tiles are 0..{tiles} and the \
                 origin lies in 0..={} (tile {tile_px} px, field {f} px)",
                tile_px - f
            )));
        }
        let nn = self.n() * self.n();
        let ons = self.with_source(py, move |source| {
            let retina = &source.retina;
            let (mut act, mut out) = (vec![0f32; nn], vec![0f32; nn]);
            retina.encode_frame(retina.pool.tile(tile), [x, y], &mut act, &mut out);
            out
        })?;
        f32_array(py, ons, &[self.n(), self.n()])
    }

    /// One training batch `(ons_t, ons_t1, shift)`: the ONS at t and t + 1, each `(B, n, n)`
    /// float32, and the eye shift between them `(B, 2)` float32 (`[dx, dy] / (field_px / 2)`:
    /// frame t + 1 samples the scene at x + d). Batches are drawn as a run's training draws
    /// them (noise included), batch k from the eye's seed and k.
    #[pyo3(signature = (batch_size=None))]
    fn batch<'py>(
        &self,
        py: Python<'py>,
        batch_size: Option<usize>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let b = self.batch_size(batch_size)?;
        self.draw(py, b)
    }

    /// An iterator of `count` batches (endless when None), as `batch` gives them.
    #[pyo3(signature = (batch_size=None, count=None))]
    fn batches(
        slf: Bound<'_, Self>,
        batch_size: Option<usize>,
        count: Option<usize>,
    ) -> PyResult<Batches> {
        let batch_size = slf.get().batch_size(batch_size)?;
        Ok(Batches {
            eye: slf.unbind(),
            batch_size,
            left: count,
        })
    }

    /// The eye's truth, for evaluation only (a model must not see it): a dict of
    /// `cone_classes` (names, e.g. `["L", "M", "S"]`), `cone_peaks_nm`, `weights` `(n, n, K)`
    /// float32 (each cone's share of each class; a pure cone has one 1), `positions_px`
    /// `(n, n, 2)` float32 (`[x, y]` in the field, x right, y down) and `field_px`.
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (n, r) = (self.n(), &self.discs);
        let k = r.mosaic.n_classes();
        let d = PyDict::new(py);
        let names: Vec<&str> = r.mosaic.classes.iter().map(|c| c.name.as_str()).collect();
        let peaks: Vec<f64> = r.mosaic.classes.iter().map(|c| c.peak_nm).collect();
        d.set_item("cone_classes", PyList::new(py, names)?)?;
        d.set_item("cone_peaks_nm", peaks)?;
        d.set_item(
            "weights",
            f32_array(py, r.mosaic.weights.clone(), &[n, n, k])?,
        )?;
        let positions: Vec<f32> = r.layout.positions_px.iter().flatten().copied().collect();
        d.set_item("positions_px", f32_array(py, positions, &[n, n, 2])?)?;
        d.set_item("field_px", r.layout.field_px)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Eye(preset={:?}, cones={:?}, seed={}): {}×{} cones on a {} px field",
            self.config.preset,
            self.config.cones,
            self.config.seed,
            self.n(),
            self.n(),
            self.field_px()
        )
    }
}

/// Batches of an eye, `count` of them or endless (`Eye.batches`).
#[pyclass(module = "colorvision._native")]
pub struct Batches {
    eye: Py<Eye>,
    batch_size: usize,
    left: Option<usize>,
}

#[pymethods]
impl Batches {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyTuple>>> {
        if self.left == Some(0) {
            return Ok(None);
        }
        if let Some(left) = &mut self.left {
            *left -= 1;
        }
        self.eye.get().draw(py, self.batch_size).map(Some)
    }
}
