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
        // (tau^2 raised to m by squaring: m reaches thousands in a row of leaves)
        (tau * tau).powi(crossings.min(i32::MAX as u32) as i32)
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
    fn each_crossing_costs_tau_squared_and_a_branch_silences() {
        assert_eq!(shading_factor(0.5, 0, false), 1.0);
        assert_eq!(shading_factor(0.5, 1, false), 0.25);
        assert_eq!(shading_factor(0.5, 3, false), 0.25f64.powi(3));
        assert_eq!(shading_factor(1.0, 1000, false), 1.0);
        assert_eq!(shading_factor(0.9, 0, true), 0.0);
        assert_eq!(shading_factor(0.01, 5000, false), 0.0);
    }
}
