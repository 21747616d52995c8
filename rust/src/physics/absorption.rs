//! Atmospheric absorption of sound, ISO 9613-1:1993 (pure-tone formula).

use crate::error::{invalid, Result};

/// Air state for ISO 9613-1. Temperature in degrees Celsius, relative humidity in percent,
/// pressure in pascals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Atmosphere {
    pub temperature_c: f64,
    pub relative_humidity: f64,
    pub pressure_pa: f64,
}

impl Default for Atmosphere {
    fn default() -> Self {
        Atmosphere {
            temperature_c: 20.0,
            relative_humidity: 50.0,
            pressure_pa: 101_325.0,
        }
    }
}

/// The pressures the absorption formula is used for (Pa): ISO 9613-1 covers air up to 200 kPa;
/// below 1 kPa (above ~50 km) its relaxation terms are outside any measured range.
pub const MIN_PRESSURE_PA: f64 = 1e3;
pub const MAX_PRESSURE_PA: f64 = 2e5;

impl Atmosphere {
    pub fn validate(&self) -> Result<()> {
        let t = self.temperature_c;
        if !(t.is_finite() && (-100.0..=100.0).contains(&t)) {
            return invalid(format!(
                "atmosphere temperature must be in [-100, 100] degC, got {t}"
            ));
        }
        let h = self.relative_humidity;
        if !(h.is_finite() && (0.0..=100.0).contains(&h)) {
            return invalid(format!(
                "atmosphere relative humidity must be in [0, 100] %, got {h}"
            ));
        }
        let p = self.pressure_pa;
        if !(MIN_PRESSURE_PA..=MAX_PRESSURE_PA).contains(&p) {
            return invalid(format!(
                "atmosphere pressure must be in [{MIN_PRESSURE_PA}, {MAX_PRESSURE_PA}] Pa, got {p}"
            ));
        }
        Ok(())
    }

    /// Absorption coefficient in dB per metre at frequency `f` (Hz), ISO 9613-1 eq. (5).
    pub fn alpha_db_per_m(&self, f: f64) -> f64 {
        let t = self.temperature_c + 273.15;
        let t0 = 293.15;
        let t01 = 273.16;
        let pr = 101_325.0;
        let pa = self.pressure_pa / pr;
        let c = -6.8346 * (t01 / t).powf(1.261) + 4.6151;
        let psat = 10f64.powf(c);
        let h = self.relative_humidity * psat / pa;
        let fro = pa * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h));
        let frn = pa
            * (t / t0).powf(-0.5)
            * (9.0 + 280.0 * h * (-4.170 * ((t / t0).powf(-1.0 / 3.0) - 1.0)).exp());
        let f2 = f * f;
        8.686
            * f2
            * (1.84e-11 / pa * (t / t0).sqrt()
                + (t / t0).powf(-2.5)
                    * (0.01275 * (-2239.1 / t).exp() / (fro + f2 / fro)
                        + 0.1068 * (-3352.0 / t).exp() / (frn + f2 / frn)))
    }

    /// The two-way amplitude absorption in nepers per metre of range at frequency `f` (Hz):
    /// `10^(-alpha 2r / 20) = exp(-(alpha ln(10) / 10) r)`, alpha in dB per metre.
    pub fn nepers_per_m(&self, f: f64) -> f64 {
        self.alpha_db_per_m(f) * std::f64::consts::LN_10 / 10.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_md_values_at_20c_50rh() {
        // docs/model.md: about 1.98, 2.29, 2.61 dB/m at 60, 70, 80 kHz, 20 degC, 50 % RH.
        let a = Atmosphere::default();
        for (f, want) in [(60e3, 1.98), (70e3, 2.29), (80e3, 2.61)] {
            let got = a.alpha_db_per_m(f);
            assert!((got - want).abs() < 0.01, "{f} Hz: {got} dB/m, want {want}");
        }
    }
}
