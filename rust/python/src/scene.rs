//! `_core.Scene`: the leaves and their BVH, built once from NumPy arrays, and the branches.

use batecho::scene::{Branches, Scene};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use std::sync::Arc;

use crate::{rows3, to_py};

/// Per point, the distance to the nearest leaf or branch surface (m) and that scatterer's
/// index.
type Clearance<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>);

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
        let scene = crate::pool::released(py, move || {
            Scene::with_branches(c, n, r, Branches::new(bs, be, br)?)
        })
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

    /// `clearance(points (n,3))`: per point, the distance (m) to the nearest leaf disk or
    /// branch cylinder and its index: the leaf's (the smallest among equally near leaves), or
    /// `-1 - j` for branch `j` (leaves first at equal distance), points in parallel.
    fn clearance<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Clearance<'py>> {
        let pts = rows3(&points, "points")?;
        let sc = self.inner.clone();
        let near = crate::pool::released(py, move || sc.clearance(&pts)).map_err(to_py)?;
        let d: Vec<f64> = near.iter().map(|n| n.distance).collect();
        let i: Vec<i64> = near
            .iter()
            .map(|n| {
                if n.branch {
                    -1 - n.index as i64
                } else {
                    n.index as i64
                }
            })
            .collect();
        Ok((d.into_pyarray(py), i.into_pyarray(py)))
    }

    /// `min_clearance(points (n,3), upper)`: the smallest distance (m) from the points to a
    /// leaf disk or branch cylinder, or `upper` if none is nearer (exact).
    fn min_clearance<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        upper: f64,
    ) -> PyResult<f64> {
        let pts = rows3(&points, "points")?;
        let sc = self.inner.clone();
        crate::pool::released(py, move || sc.min_clearance(&pts, upper)).map_err(to_py)
    }

    /// Number of BVH nodes.
    #[getter]
    fn n_nodes(&self) -> usize {
        self.inner.bvh.nodes.len()
    }
}
