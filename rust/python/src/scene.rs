//! `_core.Scene`: the leaves and their BVH, built once from NumPy arrays, and the branches.

use batecho::scene::{Branches, Scene};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use std::sync::Arc;

use crate::{rows3, to_py};

/// Leaves and their BVH (obvhs), built once, and branch segments.
#[pyclass(name = "Scene", module = "batecho._core", frozen)]
pub(crate) struct PyScene {
    pub(crate) inner: Arc<Scene>,
}

#[pymethods]
impl PyScene {
    /// `Scene(centers (n,3), unit normals (n,3), radii (n,), branch_starts (k,3), branch_ends
    /// (k,3), branch_radii (k,))`, float64, metres; `n` or `k` may be 0, not both.
    #[new]
    #[pyo3(signature = (centers, normals, radii, branch_starts=None, branch_ends=None, branch_radii=None))]
    fn new(
        py: Python<'_>,
        centers: PyReadonlyArray2<'_, f64>,
        normals: PyReadonlyArray2<'_, f64>,
        radii: PyReadonlyArray1<'_, f64>,
        branch_starts: Option<PyReadonlyArray2<'_, f64>>,
        branch_ends: Option<PyReadonlyArray2<'_, f64>>,
        branch_radii: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<Self> {
        let c = rows3(&centers, "centers")?;
        let n = rows3(&normals, "normals")?;
        let r: Vec<f64> = radii.as_array().iter().copied().collect();
        let (bs, be, br) = match (branch_starts, branch_ends, branch_radii) {
            (Some(s), Some(e), Some(a)) => (
                rows3(&s, "branch_starts")?,
                rows3(&e, "branch_ends")?,
                a.as_array().iter().copied().collect(),
            ),
            (None, None, None) => (Vec::new(), Vec::new(), Vec::new()),
            _ => {
                return Err(pyo3::exceptions::PyValueError::new_err(
                    "give branch_starts, branch_ends and branch_radii together",
                ))
            }
        };
        let scene = py
            .detach(move || Scene::with_branches(c, n, r, Branches::new(bs, be, br)?))
            .map_err(to_py)?;
        Ok(PyScene {
            inner: Arc::new(scene),
        })
    }

    #[getter]
    fn n_leaves(&self) -> usize {
        self.inner.len()
    }

    #[getter]
    fn n_branches(&self) -> usize {
        self.inner.branches.len()
    }

    /// Seconds spent building the BVH.
    #[getter]
    fn build_time_s(&self) -> f64 {
        self.inner.build_time.as_secs_f64()
    }

    /// Number of BVH nodes.
    #[getter]
    fn n_nodes(&self) -> usize {
        self.inner.bvh.nodes.len()
    }
}
