//! The sonar's parameters as given (docs/model.md §2-§5), and the model's defaults (docs/model.md).
use crate::error::Result;
use crate::physics::absorption::Atmosphere;
use crate::physics::beam::GaussianBeam;
use crate::sonar::receivers::Receiver;

/// Which leaves count (docs/model.md §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LobeRule {
    /// The authors' rule: `r <= sqrt(r0^2 p0 G / (10^(T/20) p_ref))`.
    Detectable {
        threshold_db: f64,
        r0: f64,
        p0: f64,
        p_ref: f64,
    },
    /// A hard cone: the angle between `e` and the forward axis at most `half_angle` (radians).
    Cone { half_angle: f64 },
}

/// The leaf scattering model (docs/model.md §4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LeafModel {
    /// The fit of Ming et al. (2017): `L = max(0, A(c) cos(B(c) beta))`, `psi = erf(...) - 2.6343`.
    Paper,
    /// Kirchhoff (physical optics) disk: `L = c^2/2 cos(beta) |2 J1(x)/x|`, `psi = -pi/2`.
    PhysicalOptics,
}

/// Window over the band bins.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Window {
    /// Periodic Hann of length M: `w_m = 0.5 - 0.5 cos(2 pi m / M)`.
    Hann,
    Rect,
}

/// What to do with a leaf closer than `min_range` to a pulse position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TooClose {
    Error,
    Skip,
}

/// Every parameter of the echo model, in SI units and radians.
#[derive(Clone, Debug, PartialEq)]
pub struct SonarParams {
    pub emitter: GaussianBeam,
    /// `None`: the receiver uses the emitter's pattern (two-way gain `S^2`).
    pub receiver: Option<GaussianBeam>,
    /// Receivers of their own places and patterns (docs/model.md §5a); empty: the echo is
    /// heard at the emitter (monostatic), and results have no receiver axis.
    pub receivers: Vec<Receiver>,
    pub lobe: LobeRule,
    /// Extra range limit (m); leaves are always limited to the record's range as well.
    pub max_range: Option<f64>,
    pub fs: f64,
    pub n_samples: usize,
    pub f_lo: f64,
    pub f_hi: f64,
    pub sound_speed: f64,
    pub leaf_model: LeafModel,
    pub spreading: bool,
    pub gain: f64,
    pub window: Window,
    pub atmosphere: Option<Atmosphere>,
    pub min_range: f64,
    pub too_close: TooClose,
    /// The smallest `k a` (at the band's lowest bin) for which the leaf models are used.
    pub min_ka: f64,
}

impl SonarParams {
    /// the model's defaults (docs/model.md), with a circular beam of the given full -3 dB beamwidth (radians).
    pub fn with_beamwidth(beamwidth: f64) -> Result<Self> {
        Ok(SonarParams {
            emitter: GaussianBeam::circular(beamwidth)?,
            receiver: None,
            receivers: Vec::new(),
            lobe: LobeRule::Detectable {
                threshold_db: 20.0,
                r0: 0.1,
                p0: 2.0,
                p_ref: 20e-6,
            },
            max_range: None,
            fs: 400e3,
            n_samples: 24_000,
            f_lo: 60e3,
            f_hi: 80e3,
            sound_speed: 340.0,
            leaf_model: LeafModel::Paper,
            spreading: true,
            gain: 0.2,
            window: Window::Hann,
            atmosphere: None,
            min_range: 0.01,
            too_close: TooClose::Error,
            min_ka: 0.5,
        })
    }
}
