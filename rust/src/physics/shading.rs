//! Shading (docs/model.md §10): the factor on a scatterer's amplitude from what lies between it
//! and the sonar.

/// The shading factor of a scatterer whose sonar ray crosses `crossings` leaf disks, each
/// passed twice (out and back) with the one-way amplitude transmission `tau`: `tau^(2m)`; 0
/// when a branch blocks the ray.
#[inline]
pub fn shading_factor(tau: f64, crossings: u32, blocked: bool) -> f64 {
    if blocked {
        0.0
    } else if crossings == 0 {
        1.0
    } else {
        // (m reaches thousands in a row of leaves)
        power(tau * tau, crossings)
    }
}

/// `x^n` by squaring, the multiplications in one fixed order (that of compiler-rt's
/// `__powidf2`), so that every caller gets the same bits: `powi` may be expanded otherwise
/// where the compiler knows the exponent.
fn power(x: f64, mut n: u32) -> f64 {
    let (mut base, mut acc) = (x, 1.0);
    loop {
        if n & 1 == 1 {
            acc *= base;
        }
        n >>= 1;
        if n == 0 {
            return acc;
        }
        base *= base;
    }
}

/// The shading factor of a scatterer heard by a receiver of its own (docs/model.md §10):
/// `m_out` leaf disks crossed on the way from the emitter, `m_back` on the way to the
/// receiver, `tau^(m_out + m_back)`; 0 when a branch blocks either way. With `s = m_out +
/// m_back` it is `(tau^2)^(s / 2)` (times `tau` for odd `s`), so that equal counts give
/// [`shading_factor`]'s bits.
#[inline]
pub fn two_way_shading_factor(tau: f64, m_out: u32, m_back: u32, blocked: bool) -> f64 {
    let s = m_out.saturating_add(m_back);
    let even = shading_factor(tau, s / 2, blocked);
    if s % 2 == 1 {
        even * tau
    } else {
        even
    }
}

/// [`shading_factor`] for one transmission, its values for the first counts held: the same
/// bits, without raising `tau^2` to a power for every scatterer.
pub struct ShadingFactors {
    tau: f64,
    held: [f64; Self::HELD],
}

impl ShadingFactors {
    const HELD: usize = 64;

    pub fn new(tau: f64) -> ShadingFactors {
        ShadingFactors {
            tau,
            held: std::array::from_fn(|m| shading_factor(tau, m as u32, false)),
        }
    }

    /// [`shading_factor`]`(tau, crossings, blocked)`.
    #[inline(always)]
    pub fn get(&self, crossings: u32, blocked: bool) -> f64 {
        if blocked {
            0.0
        } else if let Some(&f) = self.held.get(crossings as usize) {
            f
        } else {
            shading_factor(self.tau, crossings, false)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_ways_cost_tau_per_crossing_and_equal_counts_give_the_monostatic_bits() {
        assert_eq!(two_way_shading_factor(0.5, 0, 0, false), 1.0);
        assert_eq!(two_way_shading_factor(0.5, 1, 0, false), 0.5);
        assert_eq!(two_way_shading_factor(0.5, 0, 3, false), 0.125);
        assert_eq!(two_way_shading_factor(0.5, 2, 1, true), 0.0);
        for m in [0, 1, 2, 7, 300] {
            assert_eq!(
                two_way_shading_factor(0.6, m, m, false).to_bits(),
                shading_factor(0.6, m, false).to_bits()
            );
        }
    }

    #[test]
    fn the_power_is_the_runtime_powi_bit_for_bit() {
        let powi = std::hint::black_box(f64::powi);
        for x in [0.09, 0.36, 0.5, 0.81, 0.998_001, 1.0] {
            for n in (1..300).chain([5000, 1 << 20]) {
                let n = std::hint::black_box(n);
                assert_eq!(
                    power(x, n as u32).to_bits(),
                    powi(x, n).to_bits(),
                    "{x}^{n}"
                );
            }
        }
    }

    #[test]
    fn the_held_factors_are_the_bits_of_the_factor() {
        for tau in [0.0, 0.3, 0.6, 0.999, 1.0] {
            let held = ShadingFactors::new(tau);
            for m in (0..200).chain([5000, u32::MAX]) {
                for blocked in [false, true] {
                    assert_eq!(
                        held.get(m, blocked).to_bits(),
                        shading_factor(tau, m, blocked).to_bits(),
                        "tau {tau}, m {m}, blocked {blocked}"
                    );
                }
            }
        }
    }

    #[test]
    fn each_crossing_costs_tau_squared_and_a_branch_silences() {
        assert_eq!(shading_factor(0.5, 0, false), 1.0);
        assert_eq!(shading_factor(0.5, 1, false), 0.25);
        assert_eq!(shading_factor(0.5, 3, false), 0.25f64.powi(3));
        assert_eq!(shading_factor(1.0, 1000, false), 1.0);
        assert_eq!(shading_factor(0.9, 0, true), 0.0);
        assert_eq!(shading_factor(0.01, 5000, false), 0.0);
    }
}
