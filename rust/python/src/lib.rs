//! The Python extension `batecho._core`: conversion between NumPy arrays and the pure-Rust
//! core, and nothing else. Heavy work runs with the GIL released.

mod echoes;
mod flight;
mod obj;
mod scene;
mod sonar;

use batecho::error::Error;
use batecho::math::vec3::V3;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A core error as Python's `ValueError`, with the same message.
pub(crate) fn to_py(e: Error) -> PyErr {
    PyValueError::new_err(e.to_string())
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
    m.add_function(wrap_pyfunction!(echoes::lobe_members, m)?)?;
    m.add_function(wrap_pyfunction!(echoes::farthest_members, m)?)?;
    m.add_function(wrap_pyfunction!(obj::load_obj, m)?)?;
    m.add_class::<flight::PyAirframe>()?;
    m.add_class::<flight::PySwarm>()?;
    m.add_function(wrap_pyfunction!(flight::fly, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
