//! `simulate_many`: the band spectra of many scenes, each with poses of its own, in one call
//! (the pulses of a batch of environments), scenes and poses in parallel with the GIL released.

use batecho::simulate::many::simulate_many;
use batecho::simulate::Echoes;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{Complex64, IntoPyArray, PyArrayDyn, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::echoes::{complex_array, method_from, poses_from, search_from};
use crate::scene::PyScene;
use crate::sonar::PySonar;
use crate::to_py;

type Spectra<'py> = (
    Bound<'py, PyArrayDyn<Complex64>>,
    Bound<'py, PyArrayDyn<u64>>,
);

/// For each scene `j` and its poses (`positions[j]`, `forward[j]`, `up[j]`, `left[j]`, each
/// `(p_j, 3)`): `(spectrum (p_j, M) complex128, n_leaves (p_j,))`, with `R` receivers of their
/// own `(p_j, R, M)` and `(p_j, R)`; each equal to `simulate`'s for that scene alone.
#[pyfunction(name = "simulate_many")]
#[pyo3(signature = (scenes, sonar, positions, forward, up, left, search, method, tol))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn simulate_many_py<'py>(
    py: Python<'py>,
    scenes: Vec<PyRef<'py, PyScene>>,
    sonar: &PySonar,
    positions: Vec<PyReadonlyArray2<'py, f64>>,
    forward: Vec<PyReadonlyArray2<'py, f64>>,
    up: Vec<PyReadonlyArray2<'py, f64>>,
    left: Vec<PyReadonlyArray2<'py, f64>>,
    search: &str,
    method: &str,
    tol: f64,
) -> PyResult<Vec<Spectra<'py>>> {
    let k = scenes.len();
    if positions.len() != k || forward.len() != k || up.len() != k || left.len() != k {
        return Err(PyValueError::new_err(format!(
            "simulate_many needs one pose set per scene: {k} scenes, {} positions, {} forward, \
             {} up, {} left",
            positions.len(),
            forward.len(),
            up.len(),
            left.len()
        )));
    }
    let poses = (0..k)
        .map(|j| {
            poses_from(&positions[j], &forward[j], &up[j], &left[j])
                .map_err(|e| PyValueError::new_err(format!("scene {j}: {e}")))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let search = search_from(search)?;
    let method = method_from(method, tol)?;
    let inner: Vec<_> = scenes.iter().map(|s| s.inner.clone()).collect();
    let so = sonar.inner.clone();
    let outs = crate::pool::interruptible(py, move |stop| {
        let jobs: Vec<_> = inner
            .iter()
            .zip(&poses)
            .map(|(s, p)| (&**s, p.as_slice()))
            .collect();
        simulate_many(&jobs, &so, false, search, method, stop)
    })?
    .map_err(to_py)?;
    Ok(outs.into_iter().map(|e| spectra(py, e)).collect())
}

fn spectra(py: Python<'_>, e: Echoes) -> Spectra<'_> {
    let m = e.n_bins;
    let p = e.spectrum_re.len() / (m * e.n_receivers.max(1)).max(1);
    let lead: Vec<usize> = match e.n_receivers {
        0 => vec![p],
        r => vec![p, r],
    };
    let mut shape = lead.clone();
    shape.push(m);
    (
        complex_array(py, &shape, &e.spectrum_re, &e.spectrum_im),
        ArrayD::from_shape_vec(IxDyn(&lead), e.n_leaves)
            .expect("p * R counts")
            .into_pyarray(py),
    )
}
