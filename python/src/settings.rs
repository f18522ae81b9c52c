//! Settings from Python: a key and a value as one `--set KEY=VALUE`, so that the eye's settings
//! are resolved, validated and worded exactly as the command line's (`science::config`).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// One `KEY=VALUE` of `--set` from a Python key and value (`__` in a key reads as `.`).
pub fn setting(key: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    Ok(format!("{}={}", key.replace("__", "."), toml_value(value)?))
}

/// A Python value as TOML: bool, int, float, str, and lists or dicts of them.
fn toml_value(v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if let Ok(b) = v.downcast::<pyo3::types::PyBool>() {
        return Ok(toml::Value::Boolean(b.is_true()));
    }
    if let Ok(i) = v.extract::<i64>() {
        return Ok(toml::Value::Integer(i));
    }
    if let Ok(f) = v.extract::<f64>() {
        return Ok(toml::Value::Float(f));
    }
    if let Ok(s) = v.extract::<String>() {
        return Ok(toml::Value::String(s));
    }
    if let Ok(d) = v.downcast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            t.insert(k.extract::<String>()?, toml_value(&x)?);
        }
        return Ok(toml::Value::Table(t));
    }
    if let Ok(items) = v.try_iter() {
        return Ok(toml::Value::Array(
            items
                .map(|x| toml_value(&x?))
                .collect::<PyResult<Vec<_>>>()?,
        ));
    }
    Err(PyValueError::new_err(format!(
        "a setting's value must be a bool, number, string, list or dict, not {}",
        crate::arrays::type_name(v)
    )))
}
