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

#[cfg(test)]
mod tests {
    use super::*;

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
