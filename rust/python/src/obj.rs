//! `_core.load_obj`: an OBJ mesh as NumPy arrays.

use batecho::math::vec3::V3;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::to_py;

/// Load an OBJ mesh (see `batecho.load_obj`): `(leaf_centers (n,3), leaf_normals (n,3),
/// leaf_radii (n,), leaf_areas (n,), leaf_groups (n,) int64, bark_vertices (v,3),
/// bark_faces (f,3) int64, bark_face_groups (f,) int64, group_names, n_degenerate, warnings)`.
#[pyfunction]
#[pyo3(signature = (path, leaf_patterns=None, per="patch", up="z", scale=1.0, transform=None))]
pub(crate) fn load_obj<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    leaf_patterns: Option<Vec<String>>,
    per: &str,
    up: &str,
    scale: f64,
    transform: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
    use batecho::scene::obj::{ObjOptions, Per, Up};
    let err = |m: String| PyValueError::new_err(m);
    let per = match per {
        "patch" => Per::Patch,
        "face" => Per::Face,
        other => return Err(err(format!("per must be 'patch' or 'face', got {other:?}"))),
    };
    let up = match up {
        "z" | "Z" => Up::Z,
        "y" | "Y" => Up::Y,
        other => return Err(err(format!("up must be 'z' or 'y', got {other:?}"))),
    };
    let transform = match transform {
        None => None,
        Some(t) => {
            let a = t.as_array();
            if a.shape() != [4, 4] {
                return Err(err(format!(
                    "transform must have shape (4, 4), got {:?}",
                    a.shape()
                )));
            }
            let mut m = [[0.0; 4]; 4];
            for (i, row) in m.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    *x = a[[i, j]];
                }
            }
            Some(m)
        }
    };
    let mut opts = ObjOptions {
        per,
        up,
        scale,
        transform,
        ..ObjOptions::default()
    };
    if let Some(p) = leaf_patterns {
        opts.leaf_patterns = p;
    }
    let mesh = crate::pool::released(py, move || batecho::scene::obj::load_obj(&path, &opts))
        .map_err(to_py)?;
    let rows = |v: Vec<V3>| -> PyResult<Bound<'py, PyAny>> {
        let n = v.len();
        let flat: Vec<f64> = v.into_iter().flatten().collect();
        let a = Array2::from_shape_vec((n, 3), flat).map_err(|e| err(e.to_string()))?;
        Ok(a.into_pyarray(py).into_any())
    };
    let ints = |v: Vec<u32>| {
        v.into_iter()
            .map(i64::from)
            .collect::<Vec<i64>>()
            .into_pyarray(py)
            .into_any()
    };
    let n_faces = mesh.bark_faces.len();
    let faces: Vec<i64> = mesh
        .bark_faces
        .into_iter()
        .flatten()
        .map(i64::from)
        .collect();
    let faces = Array2::from_shape_vec((n_faces, 3), faces).map_err(|e| err(e.to_string()))?;
    let items: Vec<Bound<'py, PyAny>> = vec![
        rows(mesh.leaf_centers)?,
        rows(mesh.leaf_normals)?,
        mesh.leaf_radii.into_pyarray(py).into_any(),
        mesh.leaf_areas.into_pyarray(py).into_any(),
        ints(mesh.leaf_groups),
        rows(mesh.bark_vertices)?,
        faces.into_pyarray(py).into_any(),
        ints(mesh.bark_face_groups),
        mesh.group_names.into_pyobject(py)?.into_any(),
        mesh.n_degenerate_faces.into_pyobject(py)?.into_any(),
        mesh.warnings.into_pyobject(py)?.into_any(),
    ];
    pyo3::types::PyTuple::new(py, items)
}
