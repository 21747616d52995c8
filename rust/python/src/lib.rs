//! The Python extension `batecho._core`: conversion between NumPy arrays and the pure-Rust
//! core, and nothing else. Heavy work runs with the GIL released.

mod batch;
mod echoes;
mod flight;
mod obj;
mod pool;
mod scene;
mod sonar;

use batecho::error::Error;
use batecho::math::vec3::V3;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::{PyMemoryError, PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A core error as Python's `ValueError` (`MemoryError` for a request over the memory
/// limit), with the same message.
pub(crate) fn to_py(e: Error) -> PyErr {
    match e {
        Error::TooLarge(msg) => PyMemoryError::new_err(msg),
        other => PyValueError::new_err(other.to_string()),
    }
}

/// A Python integer as a `usize`, or a `ValueError`/`TypeError` that names the parameter and
/// the value (pyo3's own conversion says only "can't convert negative int to unsigned").
pub(crate) fn unsigned(x: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    if x.is_instance_of::<pyo3::types::PyBool>() || !x.is_instance_of::<pyo3::types::PyInt>() {
        let index = x.call_method0("__index__").ok();
        return match index {
            Some(i) if !x.is_instance_of::<pyo3::types::PyBool>() => unsigned(&i, name),
            _ => Err(PyTypeError::new_err(format!(
                "{name} must be an integer, got {}",
                x.repr().map_or_else(|_| "?".into(), |r| r.to_string())
            ))),
        };
    }
    x.extract::<usize>().map_err(|_| {
        PyValueError::new_err(format!(
            "{name} must be an integer in [0, {}], got {}",
            usize::MAX,
            x.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        ))
    })
}

/// The memory limit (bytes) on what one call may allocate (see `batecho.set_memory_limit`).
#[pyfunction]
fn memory_limit() -> u64 {
    batecho::budget::limit_bytes()
}

/// Set the memory limit (bytes); returns the previous one.
#[pyfunction]
fn set_memory_limit(bytes: &Bound<'_, PyAny>) -> PyResult<u64> {
    let b = unsigned(bytes, "bytes")?;
    batecho::budget::set_limit_bytes(b as u64).map_err(to_py)
}

/// The rows of an `(n, 3)` array; a `ValueError` naming `name` for another shape.
pub(crate) fn rows3(a: &PyReadonlyArray2<'_, f64>, name: &str) -> PyResult<Vec<V3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (n, 3), got {:?}",
            v.shape()
        )));
    }
    Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::PyScene>()?;
    m.add_class::<sonar::PySonar>()?;
    m.add_function(wrap_pyfunction!(echoes::simulate_py, m)?)?;
    m.add_function(wrap_pyfunction!(batch::simulate_many_py, m)?)?;
    m.add_function(wrap_pyfunction!(echoes::lobe_members, m)?)?;
    m.add_function(wrap_pyfunction!(echoes::leaf_sights, m)?)?;
    m.add_function(wrap_pyfunction!(echoes::farthest_members, m)?)?;
    m.add_function(wrap_pyfunction!(obj::load_obj, m)?)?;
    m.add_class::<flight::PyAirframe>()?;
    m.add_class::<flight::PySwarm>()?;
    m.add_function(wrap_pyfunction!(flight::fly, m)?)?;
    m.add_function(wrap_pyfunction!(memory_limit, m)?)?;
    m.add_function(wrap_pyfunction!(set_memory_limit, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
