//! A validated sonar ([`Sonar`]): its parameters checked, and the quantities derived from them
//! once (band bins, frequencies, wavenumbers, window, absorption per bin, detection constant,
//! range limit).
use crate::budget;
use crate::error::{invalid, Result};
use crate::physics::amplitude::detection_constant;
use crate::physics::beam::GaussianBeam;
use crate::sonar::params::LobeRule;
use crate::sonar::params::SonarParams;
use crate::sonar::params::Window;
use std::f64::consts::PI;

/// `round(x)` with halves away from zero (MATLAB's `round`), for non-negative `x`.
#[inline]
pub fn round_half_up(x: f64) -> f64 {
    (x + 0.5).floor()
}

/// Wavenumber (rad/m) at the fractional band-bin position `x` (bin `k0 + x`).
fn band_wavenumber_at(p: &SonarParams, k0: usize, x: f64) -> f64 {
    2.0 * PI * ((k0 as f64 + x) * p.fs / p.n_samples as f64) / p.sound_speed
}

/// Absorption in nepers per metre of range at the fractional band-bin position `x`.
fn band_atten_at(p: &SonarParams, k0: usize, x: f64) -> f64 {
    p.atmosphere.map_or(0.0, |a| {
        a.nepers_per_m((k0 as f64 + x) * p.fs / p.n_samples as f64)
    })
}

/// A validated sonar: its parameters and the band quantities derived from them.
#[derive(Clone, Debug)]
pub struct Sonar {
    pub params: SonarParams,
    /// First and last band bin (inclusive) of the length-`n` rFFT.
    pub k0: usize,
    pub k1: usize,
    /// Band-bin frequencies `k fs / n` (Hz), wavenumbers `2 pi f / v` (rad/m), window.
    pub freqs: Vec<f64>,
    pub wavenumbers: Vec<f64>,
    pub window: Vec<f64>,
    /// `r0^2 p0 / (10^(T/20) p_ref)` (m^2) for the detectable rule; `r_max^2 = K G`.
    pub reach_sq_per_gain: f64,
    /// cos(half angle) for the cone rule.
    pub cos_half_angle: f64,
    /// Leaves farther than this (m) never count: `min(max_range, v n / (2 fs))`.
    pub range_limit: f64,
    /// Absorption per band bin, in nepers of amplitude per metre of range (two-way, so the
    /// factor is `exp(-atten * r)`); empty when absorption is off.
    pub atten_per_m: Vec<f64>,
}

impl Sonar {
    pub fn new(params: SonarParams) -> Result<Sonar> {
        let p = &params;
        let pos = |name: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                invalid(format!("{name} must be finite and > 0, got {v}"))
            }
        };
        pos("fs", p.fs)?;
        pos("sound_speed", p.sound_speed)?;
        pos("gain", p.gain)?;
        pos("min_range", p.min_range)?;
        if !(p.min_ka.is_finite() && p.min_ka >= 0.0) {
            return invalid(format!("min_ka must be finite and >= 0, got {}", p.min_ka));
        }
        if p.n_samples < 2 {
            return invalid(format!("n_samples must be at least 2, got {}", p.n_samples));
        }
        if p.n_samples > (1usize << 31) {
            return invalid(format!(
                "n_samples must be at most 2^31, got {}",
                p.n_samples
            ));
        }
        if !(p.f_lo.is_finite() && p.f_hi.is_finite() && 0.0 < p.f_lo && p.f_lo < p.f_hi) {
            return invalid(format!(
                "band must satisfy 0 < f_lo < f_hi, got ({}, {}) Hz",
                p.f_lo, p.f_hi
            ));
        }
        let nyquist = p.fs / 2.0;
        if p.f_hi > nyquist {
            return invalid(format!(
                "band upper edge {} Hz is above the Nyquist frequency fs/2 = {} Hz",
                p.f_hi, nyquist
            ));
        }
        if let Some(r) = p.max_range {
            pos("max_range", r)?;
        }
        if let Some(b) = p.receiver {
            // Re-validate (the struct fields are public).
            GaussianBeam::new(b.amplitude, b.sigma_x, b.sigma_y, b.rotation, b.az0, b.el0)?;
        }
        if !p.receivers.is_empty() && p.receiver.is_some() {
            return invalid("give the receiving pattern as receiver or as receivers, not both");
        }
        if p.receivers.len() > crate::sonar::MAX_RECEIVERS {
            return invalid(format!(
                "at most {} receivers, got {}",
                crate::sonar::MAX_RECEIVERS,
                p.receivers.len()
            ));
        }
        for (i, r) in p.receivers.iter().enumerate() {
            r.validate(i)?;
        }
        let e = p.emitter;
        GaussianBeam::new(e.amplitude, e.sigma_x, e.sigma_y, e.rotation, e.az0, e.el0)?;
        if let Some(atm) = p.atmosphere {
            atm.validate()?;
        }

        let n = p.n_samples;
        let df = p.fs / n as f64;
        let k0 = round_half_up(p.f_lo / df);
        let k1 = round_half_up(p.f_hi / df);
        if k0 < 1.0 {
            return invalid(format!(
                "band lower edge {} Hz rounds to the DC bin; raise it or n_samples",
                p.f_lo
            ));
        }
        if k1 > (n / 2) as f64 {
            return invalid(format!(
                "band upper edge {} Hz rounds to bin {k1}, above the last rFFT bin {} (Nyquist)",
                p.f_hi,
                n / 2
            ));
        }
        let (k0, k1) = (k0 as usize, k1 as usize);
        let m = k1 - k0 + 1;
        budget::check(
            budget::sonar_bytes(m, n, rayon::current_num_threads()),
            || {
                format!(
                    "a sonar with n_samples = {n}, fs = {} Hz and band_hz = ({}, {}) ({m} band \
                     bins)",
                    p.fs, p.f_lo, p.f_hi
                )
            },
            "use a shorter record (n_samples), a lower fs or a narrower band",
        )?;
        let table = || budget::with_capacity::<f64>(m, "the sonar's band tables");
        let mut freqs = table()?;
        freqs.extend((k0..=k1).map(|k| k as f64 * p.fs / n as f64));
        let mut wavenumbers = table()?;
        wavenumbers.extend(freqs.iter().map(|&f| 2.0 * PI * f / p.sound_speed));
        let mut window = table()?;
        match p.window {
            Window::Hann => {
                window.extend((0..m).map(|j| 0.5 - 0.5 * (2.0 * PI * j as f64 / m as f64).cos()))
            }
            Window::Rect => window.resize(m, 1.0),
        }

        let (reach_sq_per_gain, cos_half_angle) = match p.lobe {
            LobeRule::Detectable {
                threshold_db,
                r0,
                p0,
                p_ref,
            } => {
                if !threshold_db.is_finite() {
                    return invalid(format!("threshold_db must be finite, got {threshold_db}"));
                }
                pos("r0", r0)?;
                pos("p0", p0)?;
                pos("p_ref", p_ref)?;
                (detection_constant(threshold_db, r0, p0, p_ref), -1.0)
            }
            LobeRule::Cone { half_angle } => {
                if !(half_angle.is_finite() && half_angle > 0.0 && half_angle < PI) {
                    return invalid(format!(
                        "cone half angle must be in (0, 180) degrees, got {} deg",
                        half_angle.to_degrees()
                    ));
                }
                (f64::INFINITY, half_angle.cos())
            }
        };
        if !(reach_sq_per_gain > 0.0) {
            return invalid("the detection constant r0^2 p0 / (10^(T/20) p_ref) must be > 0");
        }
        let record_range = p.sound_speed * n as f64 / (2.0 * p.fs);
        let range_limit = match p.max_range {
            Some(r) => r.min(record_range),
            None => record_range,
        };
        let atten_per_m = match p.atmosphere {
            Some(atm) => freqs.iter().map(|&f| atm.nepers_per_m(f)).collect(),
            None => Vec::new(),
        };
        Ok(Sonar {
            params,
            k0,
            k1,
            freqs,
            wavenumbers,
            window,
            reach_sq_per_gain,
            cos_half_angle,
            range_limit,
            atten_per_m,
        })
    }

    /// Wavenumber (rad/m) at the fractional band-bin position `x` (bin `k0 + x`).
    pub fn wavenumber_at(&self, x: f64) -> f64 {
        band_wavenumber_at(&self.params, self.k0, x)
    }

    /// Absorption (nepers per metre of range, two-way) at band-bin position `x`; 0 when off.
    pub fn atten_at(&self, x: f64) -> f64 {
        band_atten_at(&self.params, self.k0, x)
    }

    /// Number of band bins M.
    pub fn n_bins(&self) -> usize {
        self.k1 - self.k0 + 1
    }

    pub fn receiver(&self) -> &GaussianBeam {
        self.params
            .receiver
            .as_ref()
            .unwrap_or(&self.params.emitter)
    }

    /// Two-way gain `G = S_tx S_rx` at (az, el), radians.
    #[inline(always)]
    pub fn two_way_gain(&self, az: f64, el: f64) -> f64 {
        let s_tx = self.params.emitter.gain(az, el);
        match &self.params.receiver {
            None => s_tx * s_tx,
            Some(rx) => s_tx * rx.gain(az, el),
        }
    }

    /// The largest two-way gain anywhere.
    pub fn peak_gain(&self) -> f64 {
        self.params.emitter.amplitude * self.receiver().amplitude
    }

    /// The largest range (m) at which any leaf can count: with receivers, the largest delay
    /// range `(r_tx + r_rx) / 2`, at most `sqrt(K A_tx A_rx + |o|^2 / 4)` for a receiver at
    /// offset `o` (`r_tx r_rx <= K A_tx A_rx` and `|r_tx - r_rx| <= |o|`).
    pub fn max_reach(&self) -> f64 {
        match self.params.lobe {
            LobeRule::Detectable { .. } if self.params.receivers.is_empty() => {
                (self.reach_sq_per_gain * self.peak_gain())
                    .sqrt()
                    .min(self.range_limit)
            }
            LobeRule::Detectable { .. } => {
                let e = &self.params.emitter;
                let reach = self.params.receivers.iter().fold(0.0f64, |m, r| {
                    let a_rx = r.pattern(e).amplitude;
                    let o = crate::math::vec3::norm(r.offset);
                    m.max((self.reach_sq_per_gain * e.amplitude * a_rx + o * o / 4.0).sqrt())
                });
                reach.min(self.range_limit)
            }
            LobeRule::Cone { .. } => self.range_limit,
        }
    }
}
