//! batecho: foliage echoes for bat-inspired sonar (the pure-Rust core).
//!
//! The numeric kernels here use no pyo3; the Python extension `batecho._core` is the crate in
//! `rust/python`, so `cargo test` and `cargo bench` run without Python.
//! Units: metres, seconds, hertz, radians.

// `!(x <= y)` is used on purpose throughout: it is true for NaN, so NaN never passes a check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod budget;
pub mod echo;
pub mod error;
pub mod fast;
pub mod flight;
pub mod interrupt;
pub mod lobe;
pub mod math;
pub mod physics;
pub mod scene;
pub mod shade;
pub mod simulate;
pub mod sonar;

pub use error::{Error, Result};

/// Helpers shared by the unit tests.
#[cfg(test)]
pub(crate) mod test_util {
    /// Uniform numbers in [0, 1) from a 64-bit LCG seeded with `seed` (deterministic, no crates).
    pub(crate) fn uniforms(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A direction uniform on the sphere, from two of `u`'s numbers.
    pub(crate) fn unit_vector(u: &mut impl FnMut() -> f64) -> [f64; 3] {
        let (z, ph) = (2.0 * u() - 1.0, 2.0 * std::f64::consts::PI * u());
        let q = (1.0 - z * z).sqrt();
        [q * ph.cos(), q * ph.sin(), z]
    }

    /// A sonar with a 30 degree beam and the defaults, as `edit` changes them.
    pub(crate) fn sonar_with(
        edit: impl FnOnce(&mut crate::sonar::SonarParams),
    ) -> crate::fast::FastSonar {
        let mut p = crate::sonar::SonarParams::with_beamwidth(30f64.to_radians()).unwrap();
        edit(&mut p);
        crate::fast::FastSonar::new(crate::sonar::Sonar::new(p).unwrap())
    }

    /// [`sonar_with`] with the exact kernel's tables only.
    pub(crate) fn prepared_with(
        edit: impl FnOnce(&mut crate::sonar::SonarParams),
    ) -> crate::echo::Prepared {
        let mut p = crate::sonar::SonarParams::with_beamwidth(30f64.to_radians()).unwrap();
        edit(&mut p);
        crate::echo::Prepared::new(crate::sonar::Sonar::new(p).unwrap())
    }

    /// Relative L2 distance of the spectrum `a` from `b` (real and imaginary parts).
    pub(crate) fn rel_l2(a: (&[f64], &[f64]), b: (&[f64], &[f64])) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for j in 0..a.0.len() {
            num += (a.0[j] - b.0[j]).powi(2) + (a.1[j] - b.1[j]).powi(2);
            den += b.0[j].powi(2) + b.1[j].powi(2);
        }
        (num / den).sqrt()
    }

    /// [`rel_l2`] of owned `(re, im)` pairs.
    pub(crate) fn rel_l2_pair(a: &(Vec<f64>, Vec<f64>), b: &(Vec<f64>, Vec<f64>)) -> f64 {
        rel_l2((&a.0, &a.1), (&b.0, &b.1))
    }
}
