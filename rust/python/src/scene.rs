//! `_core.Scene`: the leaves and their BVH, built once from NumPy arrays.

use batecho::scene::Scene;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use std::sync::Arc;

use crate::{rows3, to_py};

/// Per point, the distance to the nearest leaf (m) and that leaf's index.
type Clearance<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>);

/// Leaves and their BVH (obvhs), built once.
#[pyclass(name = "Scene", module = "batecho._core", frozen)]
pub(crate) struct PyScene {
    pub(crate) inner: Arc<Scene>,
}

#[pymethods]
impl PyScene {
    /// `Scene(centers (n,3), unit normals (n,3), radii (n,))`, float64, metres.
    #[new]
    fn new(
        py: Python<'_>,
        centers: PyReadonlyArray2<'_, f64>,
        normals: PyReadonlyArray2<'_, f64>,
        radii: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Self> {
        let c = rows3(&centers, "centers")?;
        let n = rows3(&normals, "normals")?;
        let r: Vec<f64> = radii.as_array().iter().copied().collect();
        let scene = py.detach(move || Scene::new(c, n, r)).map_err(to_py)?;
        Ok(PyScene {
            inner: Arc::new(scene),
        })
    }

    #[getter]
    fn n_leaves(&self) -> usize {
        self.inner.len()
    }

    /// Seconds spent building the BVH.
    #[getter]
    fn build_time_s(&self) -> f64 {
        self.inner.build_time.as_secs_f64()
    }

    /// `clearance(points (n,3))`: per point, the distance (m) to the nearest leaf disk and
    /// that leaf's index (the smallest among equally near leaves), points in parallel.
    fn clearance<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Clearance<'py>> {
        let pts = rows3(&points, "points")?;
        let sc = self.inner.clone();
        let near = py.detach(move || sc.clearance(&pts)).map_err(to_py)?;
        let d: Vec<f64> = near.iter().map(|n| n.distance).collect();
        let i: Vec<i64> = near.iter().map(|n| n.index as i64).collect();
        Ok((d.into_pyarray(py), i.into_pyarray(py)))
    }

    /// Number of BVH nodes.
    #[getter]
    fn n_nodes(&self) -> usize {
        self.inner.bvh.nodes.len()
    }
}
