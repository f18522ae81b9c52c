//! NumPy in and out: any array-like read as contiguous float32 (a NumPy array of any float
//! dtype, a CPU tensor without gradient), checked for shape and finite values with errors that
//! name the argument; Rust buffers handed back as NumPy arrays.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A float32 array read from Python: its shape and its values, row-major.
pub struct Floats {
    /// The shape.
    pub shape: Vec<usize>,
    /// The values.
    pub values: Vec<f32>,
}

/// `obj` as contiguous float32 (`numpy.ascontiguousarray(obj, dtype=float32)`); `what` names it
/// in the error.
pub fn read_f32(py: Python<'_>, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Floats> {
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float32")?;
    let array = np
        .call_method("ascontiguousarray", (obj,), Some(&kwargs))
        .map_err(|e| {
            PyValueError::new_err(format!(
                "{what}: a {} cannot be read as a float32 array ({e}); give a NumPy array or \
                 a CPU tensor without gradient (`tensor.detach().cpu().numpy()`)",
                type_name(obj)
            ))
        })?;
    let array: PyReadonlyArrayDyn<'_, f32> = array.extract()?;
    let shape = array.shape().to_vec();
    let values = array.as_slice()?.to_vec();
    Ok(Floats { shape, values })
}

/// The Python type name of `obj`.
pub fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "object".into())
}

/// `(a, b, …)` as Python writes a shape.
pub fn shape_text(shape: &[usize]) -> String {
    let parts: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    match parts.len() {
        1 => format!("({},)", parts[0]),
        _ => format!("({})", parts.join(", ")),
    }
}

/// The first non-finite value of a `(N, C, n, n)` block as an error naming `what` and where.
pub fn check_finite(values: &[f32], shape: &[usize], what: &str) -> PyResult<()> {
    let Some(i) = values.iter().position(|v| !v.is_finite()) else {
        return Ok(());
    };
    let mut at = Vec::with_capacity(shape.len());
    let mut rest = i;
    for d in (0..shape.len()).rev() {
        at.push(rest % shape[d].max(1));
        rest /= shape[d].max(1);
    }
    at.reverse();
    Err(PyValueError::new_err(format!(
        "{what} is {} at index {}: percepts must be finite (a NaN is an error, not a failed \
         match)",
        values[i],
        shape_text(&at)
    )))
}

/// A float32 NumPy array of `shape` holding `values`.
pub fn f32_array<'py>(
    py: Python<'py>,
    values: Vec<f32>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, values)
        .reshape(shape.to_vec())?
        .into_any())
}

/// A float64 NumPy array (1-D).
pub fn f64_array<'py>(py: Python<'py>, values: Vec<f64>) -> Bound<'py, PyAny> {
    PyArray1::from_vec(py, values).into_any()
}
