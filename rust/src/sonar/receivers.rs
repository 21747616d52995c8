//! Receivers of their own (docs/model.md §5a): a place in the sonar's frame and a receiving
//! pattern in that frame. A sonar without receivers hears at the emitter (monostatic).

use crate::error::{invalid, Result};
use crate::math::vec3::{is_finite3, norm, V3};
use crate::physics::beam::GaussianBeam;

/// The most receivers one sonar may have.
pub const MAX_RECEIVERS: usize = 64;

/// A receiver: its offset `(forward, left, up)` (m) from the emitter in the sonar's frame, and
/// its one-way pattern (in the sonar's frame; `None`: the emitter's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Receiver {
    pub offset: V3,
    pub beam: Option<GaussianBeam>,
}

impl Receiver {
    /// A receiver at the emitter with the emitter's pattern (the monostatic case).
    pub fn at_emitter() -> Receiver {
        Receiver {
            offset: [0.0; 3],
            beam: None,
        }
    }

    /// Check the offset (finite) and the pattern; `i` labels errors.
    pub fn validate(&self, i: usize) -> Result<()> {
        if !is_finite3(self.offset) {
            return invalid(format!(
                "receiver {i}: offset_m must be finite, got {:?}",
                self.offset
            ));
        }
        if !(norm(self.offset) <= 1e6) {
            return invalid(format!(
                "receiver {i}: offset_m {:?} is farther than 1000 km from the emitter",
                self.offset
            ));
        }
        if let Some(b) = self.beam {
            GaussianBeam::new(b.amplitude, b.sigma_x, b.sigma_y, b.rotation, b.az0, b.el0)
                .map_err(|e| crate::error::Error::InvalidInput(format!("receiver {i}: {e}")))?;
        }
        Ok(())
    }

    /// The receiving pattern: its own, or the emitter's.
    #[inline(always)]
    pub fn pattern<'a>(&'a self, emitter: &'a GaussianBeam) -> &'a GaussianBeam {
        self.beam.as_ref().unwrap_or(emitter)
    }
}
