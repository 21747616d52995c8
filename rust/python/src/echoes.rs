//! The echo functions: `simulate`, `lobe_members`, `leaf_sights` and `farthest_members` over
//! poses given as NumPy arrays.

use batecho::lobe::{self, Search};
use batecho::physics::pose::Pose;
use batecho::shade::{self, Target};
use batecho::simulate;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{Complex64, IntoPyArray, PyArray1, PyArrayDyn, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::scene::PyScene;
use crate::sonar::PySonar;
use crate::{rows3, to_py};

pub(crate) fn poses_from(
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

pub(crate) fn search_from(s: &str) -> PyResult<Search> {
    match s {
        "bvh" => Ok(Search::Bvh),
        "brute_force" => Ok(Search::BruteForce),
        other => Err(PyValueError::new_err(format!(
            "search must be 'bvh' or 'brute_force', got {other:?}"
        ))),
    }
}

/// The method named `method` ("exact", "fast" or "auto"), the last two with `tol`.
pub(crate) fn method_from(method: &str, tol: f64) -> PyResult<simulate::Method> {
    match method {
        "exact" => Ok(simulate::Method::Exact),
        "fast" => Ok(simulate::Method::Fast { tol }),
        "auto" => Ok(simulate::Method::Auto { tol }),
        other => Err(PyValueError::new_err(format!(
            "method must be 'exact', 'fast' or 'auto', got {other:?}"
        ))),
    }
}

/// A complex array of `shape` from separate real and imaginary parts (as many as it holds).
pub(crate) fn complex_array<'py>(
    py: Python<'py>,
    shape: &[usize],
    re: &[f64],
    im: &[f64],
) -> Bound<'py, PyArrayDyn<Complex64>> {
    let v: Vec<Complex64> = re
        .iter()
        .zip(im)
        .map(|(&re, &im)| Complex64::new(re, im))
        .collect();
    ArrayD::from_shape_vec(IxDyn(shape), v)
        .expect("as many values as the shape holds")
        .into_pyarray(py)
}

type SimOut<'py> = (
    Bound<'py, PyArrayDyn<Complex64>>,
    Option<Bound<'py, PyArrayDyn<f64>>>,
    Bound<'py, PyArrayDyn<u64>>,
    Option<Bound<'py, PyArrayDyn<Complex64>>>,
    Bound<'py, PyArrayDyn<u64>>,
    Bound<'py, PyArrayDyn<u64>>,
);

/// Echoes of every pose: `(spectrum (p, M) complex128, impulse (p, n) or None, n_leaves (p,),
/// wood spectrum (p, M) or None without branches, n_pieces (p,), n_shaded (p,))`; with `R`
/// receivers of their own, the first three are `(p, R, M)`, `(p, R, n)` and `(p, R)`, the wood
/// spectrum `(p, R, M)`, n_pieces `(p, R)` and n_shaded `(p, R)`.
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
    let method = method_from(method, tol)?;
    let (sc, so) = (scene.inner.clone(), sonar.inner.clone());
    let poses_len = poses.len();
    let out = crate::pool::interruptible(py, move |stop| {
        simulate::simulate(&sc, &so, &poses, impulse, search, method, stop)
    })?
    .map_err(to_py)?;
    let p = poses_len;
    let m = out.n_bins;
    // (p,) or (p, R): the leading axes of every array
    let lead: Vec<usize> = match out.n_receivers {
        0 => vec![p],
        r => vec![p, r],
    };
    let shape = |last: usize| -> Vec<usize> { lead.iter().copied().chain([last]).collect() };
    let spec = complex_array(py, &shape(m), &out.spectrum_re, &out.spectrum_im);
    let wood = (!scene.inner.branches.is_empty())
        .then(|| complex_array(py, &shape(m), &out.wood_re, &out.wood_im));
    let imp = if impulse {
        let n = sonar.inner.params.n_samples;
        Some(
            ArrayD::from_shape_vec(IxDyn(&shape(n)), out.impulse)
                .expect("p * R * n values")
                .into_pyarray(py),
        )
    } else {
        None
    };
    let counts = ArrayD::from_shape_vec(IxDyn(&lead), out.n_leaves)
        .expect("p * R counts")
        .into_pyarray(py);
    let shaded = ArrayD::from_shape_vec(IxDyn(&lead), out.n_shaded)
        .expect("p * R counts")
        .into_pyarray(py);
    Ok((
        spec,
        imp,
        counts,
        wood,
        ArrayD::from_shape_vec(IxDyn(&lead), out.n_pieces)
            .expect("p * R counts")
            .into_pyarray(py),
        shaded,
    ))
}

/// Indices (ascending) of the leaves that count for one pose.
#[pyfunction]
#[pyo3(signature = (scene, sonar, position, forward, up, left, search="bvh", receiver=None))]
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
    receiver: Option<usize>,
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
    let n_rx = so.params.receivers.len();
    match receiver {
        Some(k) if k >= n_rx => {
            return Err(PyValueError::new_err(format!(
                "receiver {k} out of range: the sonar has {n_rx} receivers"
            )))
        }
        None if n_rx > 0 => {
            return Err(PyValueError::new_err(format!(
                "the sonar has {n_rx} receivers of their own: pass receiver= (an index)"
            )))
        }
        _ => {}
    }
    let ids = crate::pool::released(py, move || {
        let ids = match receiver {
            None => lobe::members(&sc, &so, &pose, 0, search)
                .map(|mem| mem.iter().map(|m| m.index).collect::<Vec<u32>>()),
            Some(k) => simulate::receivers::heard_members(&sc, &so, &pose, search, k),
        };
        ids.map(|ids| {
            let mut ids: Vec<i64> = ids.iter().map(|&i| sc.ids[i as usize] as i64).collect();
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
    let rows = crate::pool::released(py, move || {
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
    let r = crate::pool::released(py, move || {
        simulate::farthest_members(&sc, &so, &poses, Search::Bvh)
    })
    .map_err(to_py)?;
    Ok(r.into_pyarray(py))
}
