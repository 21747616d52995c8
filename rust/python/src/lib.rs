//! The Python extension `batecho._core`: conversion between NumPy arrays and the pure-Rust
//! core, and nothing else. Heavy work runs with the GIL released.

use batecho::error::Error;
use batecho::fast::FastSonar;
use batecho::lobe::{self, Search};
use batecho::math::vec3::V3;
use batecho::physics::absorption::Atmosphere;
use batecho::physics::beam::GaussianBeam;
use batecho::physics::pose::Pose;
use batecho::scene::Scene;
use batecho::simulate;
use batecho::sonar::{LeafModel, LobeRule, Sonar, SonarParams, TooClose, Window};
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::Arc;

fn to_py(e: Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn rows3(a: &PyReadonlyArray2<'_, f64>, name: &str) -> PyResult<Vec<V3>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (n, 3), got {:?}",
            v.shape()
        )));
    }
    Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// Leaves and their BVH (obvhs), built once.
#[pyclass(name = "Scene", module = "batecho._core", frozen)]
struct PyScene {
    inner: Arc<Scene>,
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

    /// Number of BVH nodes.
    #[getter]
    fn n_nodes(&self) -> usize {
        self.inner.bvh.nodes.len()
    }
}

fn beam_from(spec: (f64, f64, f64, f64, f64, f64)) -> Result<GaussianBeam, Error> {
    let (amp, sx, sy, rot, az0, el0) = spec;
    GaussianBeam::new(amp, sx, sy, rot, az0, el0)
}

/// A validated sonar with its derived tables. Angles in radians; see `batecho.Sonar`.
#[pyclass(name = "Sonar", module = "batecho._core", frozen)]
struct PySonar {
    /// The parameters (`inner.sonar`) with every kernel's cache.
    inner: Arc<FastSonar>,
}

#[pymethods]
impl PySonar {
    #[new]
    #[pyo3(signature = (
        emitter, receiver, lobe, threshold_db, r0, p0, p_ref, cone_half_angle, max_range,
        fs, n_samples, f_lo, f_hi, sound_speed, leaf_model, spreading, gain, window,
        atmosphere, min_range, too_close, min_ka
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        emitter: (f64, f64, f64, f64, f64, f64),
        receiver: Option<(f64, f64, f64, f64, f64, f64)>,
        lobe: &str,
        threshold_db: f64,
        r0: f64,
        p0: f64,
        p_ref: f64,
        cone_half_angle: Option<f64>,
        max_range: Option<f64>,
        fs: f64,
        n_samples: usize,
        f_lo: f64,
        f_hi: f64,
        sound_speed: f64,
        leaf_model: &str,
        spreading: bool,
        gain: f64,
        window: &str,
        atmosphere: Option<(f64, f64, f64)>,
        min_range: f64,
        too_close: &str,
        min_ka: f64,
    ) -> PyResult<Self> {
        let err = |m: String| PyValueError::new_err(m);
        let lobe = match lobe {
            "detectable" => LobeRule::Detectable {
                threshold_db,
                r0,
                p0,
                p_ref,
            },
            "cone" => LobeRule::Cone {
                half_angle: cone_half_angle
                    .ok_or_else(|| err("lobe 'cone' needs cone_half_angle".into()))?,
            },
            other => {
                return Err(err(format!(
                    "lobe must be 'detectable' or 'cone', got {other:?}"
                )))
            }
        };
        let leaf_model = match leaf_model {
            "paper" => LeafModel::Paper,
            "physical_optics" => LeafModel::PhysicalOptics,
            other => {
                return Err(err(format!(
                    "leaf_model must be 'paper' or 'physical_optics', got {other:?}"
                )))
            }
        };
        let window = match window {
            "hann" => Window::Hann,
            "rect" => Window::Rect,
            other => {
                return Err(err(format!(
                    "window must be 'hann' or 'rect', got {other:?}"
                )))
            }
        };
        let too_close = match too_close {
            "raise" => TooClose::Error,
            "skip" => TooClose::Skip,
            other => {
                return Err(err(format!(
                    "too_close must be 'raise' or 'skip', got {other:?}"
                )))
            }
        };
        let params = SonarParams {
            emitter: beam_from(emitter).map_err(to_py)?,
            receiver: receiver.map(beam_from).transpose().map_err(to_py)?,
            lobe,
            max_range,
            fs,
            n_samples,
            f_lo,
            f_hi,
            sound_speed,
            leaf_model,
            spreading,
            gain,
            window,
            atmosphere: atmosphere.map(|(t, h, p)| Atmosphere {
                temperature_c: t,
                relative_humidity: h,
                pressure_pa: p,
            }),
            min_range,
            too_close,
            min_ka,
        };
        Ok(PySonar {
            inner: Arc::new(FastSonar::new(Sonar::new(params).map_err(to_py)?)),
        })
    }

    /// Band-bin frequencies (Hz).
    #[getter]
    fn freqs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.freqs.clone().into_pyarray(py)
    }

    /// First and last band bin of the length-n rFFT.
    #[getter]
    fn bins(&self) -> (usize, usize) {
        (self.inner.k0, self.inner.k1)
    }

    /// Leaves beyond this range (m) never count.
    #[getter]
    fn range_limit(&self) -> f64 {
        self.inner.range_limit
    }

    /// The largest range (m) at which a leaf can count.
    #[getter]
    fn max_reach(&self) -> f64 {
        self.inner.max_reach()
    }

    /// Absorption per band bin (dB/m), or None.
    #[getter]
    fn absorption_db_per_m<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner.params.atmosphere.map(|a| {
            self.inner
                .freqs
                .iter()
                .map(|&f| a.alpha_db_per_m(f))
                .collect::<Vec<_>>()
                .into_pyarray(py)
        })
    }
}

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
);

/// Echoes of every pose: `(spectrum (p, M) complex128, impulse (p, n) or None, n_leaves (p,))`.
/// `method` is "exact", "fast" or "auto" (the last two use `tol`); both are required, so that
/// the defaults live in one place (`batecho.simulate`).
#[pyfunction(name = "simulate")]
#[pyo3(signature = (scene, sonar, positions, forward, up, left, impulse, search, method, tol))]
#[allow(clippy::too_many_arguments)]
fn simulate_py<'py>(
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
    let spec: Vec<Complex64> = out
        .spectrum_re
        .iter()
        .zip(&out.spectrum_im)
        .map(|(&re, &im)| Complex64::new(re, im))
        .collect();
    let spec = Array2::from_shape_vec((p, m), spec)
        .expect("p * M values")
        .into_pyarray(py);
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
    Ok((spec, imp, out.n_leaves.into_pyarray(py)))
}

/// Indices (ascending) of the leaves that count for one pose.
#[pyfunction]
#[pyo3(signature = (scene, sonar, position, forward, up, left, search="bvh"))]
#[allow(clippy::too_many_arguments)]
fn lobe_members<'py>(
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

/// Load an OBJ mesh (see `batecho.load_obj`): `(leaf_centers (n,3), leaf_normals (n,3),
/// leaf_radii (n,), leaf_areas (n,), leaf_groups (n,) int64, bark_vertices (v,3),
/// bark_faces (f,3) int64, bark_face_groups (f,) int64, group_names, n_degenerate, warnings)`.
#[pyfunction]
#[pyo3(signature = (path, leaf_patterns=None, per="patch", up="z", scale=1.0, transform=None))]
fn load_obj<'py>(
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
    let mesh = py
        .detach(move || batecho::scene::obj::load_obj(&path, &opts))
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

/// The range (m) of the farthest counting leaf of each pose (0 where none counts).
#[pyfunction]
#[pyo3(signature = (scene, sonar, positions, forward, up, left))]
fn farthest_members<'py>(
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

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScene>()?;
    m.add_class::<PySonar>()?;
    m.add_function(wrap_pyfunction!(simulate_py, m)?)?;
    m.add_function(wrap_pyfunction!(lobe_members, m)?)?;
    m.add_function(wrap_pyfunction!(farthest_members, m)?)?;
    m.add_function(wrap_pyfunction!(load_obj, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
