//! Sonar parameters (docs/model.md §2-§5) and the quantities derived from them once:
//! the band bins, frequencies, wavenumbers and window, the detection constant, the range limit;
//! receivers at their own places.
//! No kernel's cache lives here: see [`crate::echo::Prepared`] and [`crate::fast::FastSonar`].

pub mod band;
pub mod params;
pub mod receivers;

pub use band::{round_half_up, Sonar};
pub use params::{LeafModel, LobeRule, SonarParams, TooClose, Window};
pub use receivers::{Receiver, MAX_RECEIVERS};
