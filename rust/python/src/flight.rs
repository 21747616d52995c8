//! The quadrotor: `Airframe` (the vehicle and its gains), `fly` (a reference flown from a
//! state) and `Swarm` (drones stepped under velocity commands), as NumPy arrays.

use batecho::flight::{
    self, Airframe, AirframeParams, Configuration, Gains, Reference, StateVec, VelocityCommand,
};
use batecho::math::vec3::V3;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::{rows3, to_py};

fn triple(v: PyReadonlyArray1<'_, f64>, name: &str) -> PyResult<V3> {
    let a = v.as_array();
    if a.len() != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} must have 3 entries, got {}",
            a.len()
        )));
    }
    Ok([a[0], a[1], a[2]])
}

fn states_from(a: &PyReadonlyArray2<'_, f64>, name: &str) -> PyResult<Vec<StateVec>> {
    let v = a.as_array();
    if v.ncols() != 22 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (n, 22), got {:?}",
            v.shape()
        )));
    }
    Ok(v.rows()
        .into_iter()
        .map(|r| std::array::from_fn(|i| r[i]))
        .collect())
}

fn states_to<'py>(py: Python<'py>, states: &[StateVec]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = states.iter().flatten().copied().collect();
    Array2::from_shape_vec((states.len(), 22), flat)
        .expect("n * 22 values")
        .into_pyarray(py)
}

/// A quadrotor's parameters and controller gains, checked (docs/model.md §8).
#[pyclass(name = "Airframe", module = "batecho._core", frozen)]
pub(crate) struct PyAirframe {
    pub(crate) inner: Airframe,
}

#[pymethods]
impl PyAirframe {
    #[new]
    #[pyo3(signature = (*, mass, inertia, arm_length, k_f, k_m, motor_time_constant,
        omega_min, omega_max, drag, configuration, gravity, k_x, k_v, k_R, k_Omega,
        drag_feedforward))]
    #[allow(clippy::too_many_arguments, non_snake_case)]
    fn new(
        mass: f64,
        inertia: PyReadonlyArray1<'_, f64>,
        arm_length: f64,
        k_f: f64,
        k_m: f64,
        motor_time_constant: f64,
        omega_min: f64,
        omega_max: f64,
        drag: PyReadonlyArray1<'_, f64>,
        configuration: &str,
        gravity: f64,
        k_x: PyReadonlyArray1<'_, f64>,
        k_v: PyReadonlyArray1<'_, f64>,
        k_R: PyReadonlyArray1<'_, f64>,
        k_Omega: PyReadonlyArray1<'_, f64>,
        drag_feedforward: bool,
    ) -> PyResult<Self> {
        let configuration = match configuration {
            "x" => Configuration::X,
            "+" => Configuration::Plus,
            other => {
                return Err(PyValueError::new_err(format!(
                    "configuration must be 'x' or '+', got {other:?}"
                )))
            }
        };
        let params = AirframeParams {
            mass,
            inertia: triple(inertia, "inertia")?,
            arm_length,
            k_f,
            k_m,
            motor_time_constant,
            omega_min,
            omega_max,
            drag: triple(drag, "drag")?,
            configuration,
            gravity,
            gains: Gains {
                k_x: triple(k_x, "k_x")?,
                k_v: triple(k_v, "k_v")?,
                k_r: triple(k_R, "k_R")?,
                k_omega: triple(k_Omega, "k_Omega")?,
            },
            drag_feedforward,
        };
        Ok(PyAirframe {
            inner: Airframe::new(params).map_err(to_py)?,
        })
    }

    /// The (4, 4) mixer from rotor thrusts to (f, Mx, My, Mz).
    #[getter]
    fn mixer<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self.inner.mixer.iter().flatten().copied().collect();
        Array2::from_shape_vec((4, 4), flat)
            .expect("16 values")
            .into_pyarray(py)
    }
}

/// Flies reference samples from `y0` (22,): step k runs from `times[k]` to `times[k+1]` with
/// the controller at sample k (`p`, `v`, `a`, `omega`, `domega` (n, 3), `yaw` (n,)) and the
/// wind `wind[k]`. Returns the states (len(times), 22).
#[pyfunction]
#[pyo3(signature = (airframe, y0, p, v, a, yaw, omega, domega, wind, times))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fly<'py>(
    py: Python<'py>,
    airframe: &PyAirframe,
    y0: PyReadonlyArray1<'py, f64>,
    p: PyReadonlyArray2<'py, f64>,
    v: PyReadonlyArray2<'py, f64>,
    a: PyReadonlyArray2<'py, f64>,
    yaw: PyReadonlyArray1<'py, f64>,
    omega: PyReadonlyArray2<'py, f64>,
    domega: PyReadonlyArray2<'py, f64>,
    wind: PyReadonlyArray2<'py, f64>,
    times: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let y0 = y0.as_array();
    if y0.len() != 22 {
        return Err(PyValueError::new_err(format!(
            "initial state must have 22 entries, got {}",
            y0.len()
        )));
    }
    let y0: StateVec = std::array::from_fn(|i| y0[i]);
    let (p, v, a) = (rows3(&p, "p")?, rows3(&v, "v")?, rows3(&a, "a")?);
    let (omega, domega) = (rows3(&omega, "omega")?, rows3(&domega, "domega")?);
    let yaw = yaw.as_array();
    let n = p.len();
    if [v.len(), a.len(), omega.len(), domega.len(), yaw.len()]
        .iter()
        .any(|&m| m != n)
    {
        return Err(PyValueError::new_err("reference arrays differ in length"));
    }
    let refs: Vec<Reference> = (0..n)
        .map(|k| Reference {
            position: p[k],
            velocity: v[k],
            acceleration: a[k],
            yaw: yaw[k],
            omega: omega[k],
            domega: domega[k],
        })
        .collect();
    let wind = rows3(&wind, "wind")?;
    let times: Vec<f64> = times.as_array().iter().copied().collect();
    let af = &airframe.inner;
    let out =
        crate::pool::released(py, || flight::fly(af, &y0, &refs, &wind, &times)).map_err(to_py)?;
    Ok(states_to(py, &out))
}

/// Drones of one airframe stepped together under velocity-and-yaw-rate commands.
#[pyclass(name = "Swarm", module = "batecho._core")]
pub(crate) struct PySwarm {
    inner: flight::Swarm,
}

#[pymethods]
impl PySwarm {
    /// `Swarm(airframe, states (n, 22))`.
    #[new]
    fn new(airframe: &PyAirframe, states: PyReadonlyArray2<'_, f64>) -> PyResult<Self> {
        let states = states_from(&states, "states")?;
        Ok(PySwarm {
            inner: flight::Swarm::new(airframe.inner.clone(), states).map_err(to_py)?,
        })
    }

    /// Puts the drones at `states` (n, 22).
    fn reset(&mut self, states: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        let states = states_from(&states, "states")?;
        self.inner.reset(states).map_err(to_py)
    }

    /// The states (n, 22).
    #[getter]
    fn states<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        states_to(py, self.inner.states())
    }

    #[getter]
    fn n_drones(&self) -> usize {
        self.inner.len()
    }

    /// Flies `n_steps` steps of `dt` s, drone i under `velocities[i]` (world, m/s),
    /// `yaw_rates[i]` (rad/s) and `wind[i]` (m/s). Returns the positions after each step
    /// (n, n_steps, 3).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        velocities: PyReadonlyArray2<'py, f64>,
        yaw_rates: PyReadonlyArray1<'py, f64>,
        wind: PyReadonlyArray2<'py, f64>,
        dt: f64,
        n_steps: usize,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let vel = rows3(&velocities, "velocities")?;
        let rates = yaw_rates.as_array();
        if rates.len() != vel.len() {
            return Err(PyValueError::new_err(format!(
                "yaw_rates must have {} entries, got {}",
                vel.len(),
                rates.len()
            )));
        }
        let cmds: Vec<VelocityCommand> = vel
            .iter()
            .zip(rates.iter())
            .map(|(&velocity, &yaw_rate)| VelocityCommand { velocity, yaw_rate })
            .collect();
        let wind = rows3(&wind, "wind")?;
        let swarm = &mut self.inner;
        let path =
            crate::pool::released(py, || swarm.step(&cmds, &wind, dt, n_steps)).map_err(to_py)?;
        let n = cmds.len();
        let flat: Vec<f64> = path.iter().flatten().copied().collect();
        Ok(Array3::from_shape_vec((n, n_steps, 3), flat)
            .expect("n * n_steps * 3 values")
            .into_pyarray(py))
    }
}
