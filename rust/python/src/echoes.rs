//! The echo functions: `simulate`, `lobe_members`, `leaf_sights` and `farthest_members` over
//! poses given as NumPy arrays.

use batecho::lobe::{self, Search};
use batecho::physics::pose::Pose;
use batecho::shade::{self, Target};
use batecho::simulate;
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::scene::PyScene;
use crate::sonar::PySonar;
use crate::{rows3, to_py};

fn poses_from(
    positions: &PyReadonlyArray2<'_, f64>,
    forward: &PyReadonlyArray2<'_, f64>,
    up: &PyReadonlyArray2<'_, f64>,
    left: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Vec<Pose>> {
    let p = rows3(positions, "positions")?;
    let d = rows3(forward, "forward")?;
    let u = rows3(up, "up")?;
    let l = rows3(left, "left")?;
    if d.len() != p.len() || u.len() != p.len() || l.len() != p.len() {
        return Err(PyValueError::new_err("pose arrays differ in length"));
    }
    (0..p.len())
        .map(|i| {
            Pose::from_frame(p[i], d[i], u[i], l[i])
                .map_err(|e| PyValueError::new_err(format!("pose {i}: {e}")))
        })
        .collect()
}

fn search_from(s: &str) -> PyResult<Search> {
    match s {
        "bvh" => Ok(Search::Bvh),
        "brute_force" => Ok(Search::BruteForce),
        other => Err(PyValueError::new_err(format!(
            "search must be 'bvh' or 'brute_force', got {other:?}"
        ))),
    }
}

type SimOut<'py> = (
    Bound<'py, PyArray2<Complex64>>,
    Option<Bound<'py, PyArray2<f64>>>,
    Bound<'py, PyArray1<u64>>,
    Option<Bound<'py, PyArray2<Complex64>>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u64>>,
);

/// `(p, M)` complex values from separate real and imaginary parts.
fn complex_rows<'py>(
    py: Python<'py>,
    p: usize,
    m: usize,
    re: &[f64],
    im: &[f64],
) -> Bound<'py, PyArray2<Complex64>> {
    let v: Vec<Complex64> = re
        .iter()
        .zip(im)
        .map(|(&re, &im)| Complex64::new(re, im))
        .collect();
    Array2::from_shape_vec((p, m), v)
        .expect("p * M values")
        .into_pyarray(py)
}

/// Echoes of every pose: `(spectrum (p, M) complex128, impulse (p, n) or None, n_leaves (p,),
/// wood spectrum (p, M) or None without branches, n_pieces (p,), n_shaded (p,))`.
/// `method` is "exact", "fast" or "auto" (the last two use `tol`); both are required, so that
/// the defaults live in one place (`batecho.simulate`).
#[pyfunction(name = "simulate")]
#[pyo3(signature = (scene, sonar, positions, forward, up, left, impulse, search, method, tol))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn simulate_py<'py>(
    py: Python<'py>,
    scene: &PyScene,
    sonar: &PySonar,
    positions: PyReadonlyArray2<'py, f64>,
    forward: PyReadonlyArray2<'py, f64>,
    up: PyReadonlyArray2<'py, f64>,
    left: PyReadonlyArray2<'py, f64>,
    impulse: bool,
    search: &str,
    method: &str,
    tol: f64,
) -> PyResult<SimOut<'py>> {
    let poses = poses_from(&positions, &forward, &up, &left)?;
    let search = search_from(search)?;
    let method = match method {
        "exact" => simulate::Method::Exact,
        "fast" => simulate::Method::Fast { tol },
        "auto" => simulate::Method::Auto { tol },
        other => {
            return Err(PyValueError::new_err(format!(
                "method must be 'exact', 'fast' or 'auto', got {other:?}"
            )))
        }
    };
    let (sc, so) = (scene.inner.clone(), sonar.inner.clone());
    let out = py
        .detach(move || simulate::simulate(&sc, &so, &poses, impulse, search, method))
        .map_err(to_py)?;
    let p = out.n_leaves.len();
    let m = out.n_bins;
    let spec = complex_rows(py, p, m, &out.spectrum_re, &out.spectrum_im);
    let wood = (!scene.inner.branches.is_empty())
        .then(|| complex_rows(py, p, m, &out.wood_re, &out.wood_im));
    let imp = if impulse {
        let n = sonar.inner.params.n_samples;
        Some(
            Array2::from_shape_vec((p, n), out.impulse)
                .expect("p * n values")
                .into_pyarray(py),
        )
    } else {
        None
    };
    Ok((
        spec,
        imp,
        out.n_leaves.into_pyarray(py),
        wood,
        out.n_pieces.into_pyarray(py),
        out.n_shaded.into_pyarray(py),
    ))
}

/// Indices (ascending) of the leaves that count for one pose.
#[pyfunction]
#[pyo3(signature = (scene, sonar, position, forward, up, left, search="bvh"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn lobe_members<'py>(
    py: Python<'py>,
    scene: &PyScene,
    sonar: &PySonar,
    position: PyReadonlyArray2<'py, f64>,
    forward: PyReadonlyArray2<'py, f64>,
    up: PyReadonlyArray2<'py, f64>,
    left: PyReadonlyArray2<'py, f64>,
    search: &str,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let poses = poses_from(&position, &forward, &up, &left)?;
    if poses.len() != 1 {
        return Err(PyValueError::new_err(format!(
            "lobe_members takes one pose, got {}",
            poses.len()
        )));
    }
    let search = search_from(search)?;
    let (sc, so) = (scene.inner.clone(), sonar.inner.clone());
    let pose = poses[0];
    let ids = py
        .detach(move || {
            lobe::members(&sc, &so, &pose, 0, search).map(|mem| {
                let mut ids: Vec<i64> = mem
                    .iter()
                    .map(|m| sc.ids[m.index as usize] as i64)
                    .collect();
                ids.sort_unstable();
                ids
            })
        })
        .map_err(to_py)?;
    Ok(ids.into_pyarray(py))
}

/// Each counting leaf's caller's index, its crossings, and whether a branch blocks it.
type Sights<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<bool>>,
);

/// For each leaf that counts for one pose, by caller's index (ascending): the number of other
/// leaf disks the open segment from the sonar to its centre crosses, and whether a branch
/// cylinder blocks that segment (tested only with `branches_block`).
#[pyfunction]
#[pyo3(signature = (scene, sonar, position, forward, up, left, branches_block))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn leaf_sights<'py>(
    py: Python<'py>,
    scene: &PyScene,
    sonar: &PySonar,
    position: PyReadonlyArray2<'py, f64>,
    forward: PyReadonlyArray2<'py, f64>,
    up: PyReadonlyArray2<'py, f64>,
    left: PyReadonlyArray2<'py, f64>,
    branches_block: bool,
) -> PyResult<Sights<'py>> {
    let poses = poses_from(&position, &forward, &up, &left)?;
    if poses.len() != 1 {
        return Err(PyValueError::new_err(format!(
            "leaf_sights takes one pose, got {}",
            poses.len()
        )));
    }
    let (sc, so) = (scene.inner.clone(), sonar.inner.clone());
    let pose = poses[0];
    let rows = py
        .detach(move || {
            lobe::members(&sc, &so, &pose, 0, Search::Bvh).map(|mem| {
                let targets: Vec<Target> = mem
                    .iter()
                    .map(|m| Target::Leaf {
                        point: sc.centers.get(m.index as usize),
                        leaf: m.index,
                    })
                    .collect();
                let sights = shade::cast(&sc, pose.position, &targets, branches_block);
                let mut rows: Vec<(i64, u64, bool)> = mem
                    .iter()
                    .zip(&sights)
                    .map(|(m, s)| {
                        (
                            sc.ids[m.index as usize] as i64,
                            s.crossings as u64,
                            s.blocked,
                        )
                    })
                    .collect();
                rows.sort_unstable_by_key(|r| r.0);
                rows
            })
        })
        .map_err(to_py)?;
    let ids: Vec<i64> = rows.iter().map(|r| r.0).collect();
    let crossings: Vec<u64> = rows.iter().map(|r| r.1).collect();
    let blocked: Vec<bool> = rows.iter().map(|r| r.2).collect();
    Ok((
        ids.into_pyarray(py),
        crossings.into_pyarray(py),
        blocked.into_pyarray(py),
    ))
}

/// The range (m) of the farthest counting leaf of each pose (0 where none counts).
#[pyfunction]
#[pyo3(signature = (scene, sonar, positions, forward, up, left))]
pub(crate) fn farthest_members<'py>(
    py: Python<'py>,
    scene: &PyScene,
    sonar: &PySonar,
    positions: PyReadonlyArray2<'py, f64>,
    forward: PyReadonlyArray2<'py, f64>,
    up: PyReadonlyArray2<'py, f64>,
    left: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let poses = poses_from(&positions, &forward, &up, &left)?;
    let (sc, so) = (scene.inner.clone(), sonar.inner.clone());
    let r = py
        .detach(move || simulate::farthest_members(&sc, &so, &poses, Search::Bvh))
        .map_err(to_py)?;
    Ok(r.into_pyarray(py))
}
