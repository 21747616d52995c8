//! `_core.Sonar`: the sonar's parameters from Python's values, validated, with every
//! kernel's cache (a [`FastSonar`]).

use batecho::error::Error;
use batecho::fast::FastSonar;
use batecho::physics::absorption::Atmosphere;
use batecho::physics::beam::GaussianBeam;
use batecho::sonar::{LeafModel, LobeRule, Receiver, Sonar, SonarParams, TooClose, Window};
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::Arc;

use crate::{to_py, unsigned};

fn beam_from(spec: (f64, f64, f64, f64, f64, f64)) -> Result<GaussianBeam, Error> {
    let (amp, sx, sy, rot, az0, el0) = spec;
    GaussianBeam::new(amp, sx, sy, rot, az0, el0)
}

/// A receiver from Python: its offset `(forward, left, up)` (m) and its beam (or None).
type BeamAt = ((f64, f64, f64), Option<(f64, f64, f64, f64, f64, f64)>);

/// A validated sonar with every kernel's cache. Angles in radians; see `batecho.Sonar`.
#[pyclass(name = "Sonar", module = "batecho._core", frozen)]
pub(crate) struct PySonar {
    /// The parameters (`inner.sonar`) with every kernel's cache.
    pub(crate) inner: Arc<FastSonar>,
}

#[pymethods]
impl PySonar {
    #[new]
    #[pyo3(signature = (
        emitter, receiver, lobe, threshold_db, r0, p0, p_ref, cone_half_angle, max_range,
        fs, n_samples, f_lo, f_hi, sound_speed, leaf_model, spreading, gain, window,
        atmosphere, min_range, too_close, min_ka, receivers=None
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
        n_samples: &Bound<'_, PyAny>,
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
        receivers: Option<Vec<BeamAt>>,
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
        let receivers = receivers
            .unwrap_or_default()
            .into_iter()
            .map(|(offset, beam)| {
                Ok(Receiver {
                    offset: [offset.0, offset.1, offset.2],
                    beam: beam.map(beam_from).transpose().map_err(to_py)?,
                })
            })
            .collect::<PyResult<Vec<_>>>()?;
        let params = SonarParams {
            emitter: beam_from(emitter).map_err(to_py)?,
            receiver: receiver.map(beam_from).transpose().map_err(to_py)?,
            receivers,
            lobe,
            max_range,
            fs,
            n_samples: unsigned(n_samples, "n_samples")?,
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

    /// The number of receivers of their own (0: the echo is heard at the emitter).
    #[getter]
    fn n_receivers(&self) -> usize {
        self.inner.params.receivers.len()
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
