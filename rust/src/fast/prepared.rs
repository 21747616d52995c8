//! A sonar prepared for both methods: the exact kernel's tables ([`Prepared`]) and the fast
//! path's caches, its plans by tolerance and its sub-bands, each built on first use.

use crate::echo::Prepared;
use crate::fast::subband::SubBands;
use crate::fast::PlanCache;
use crate::sonar::Sonar;
use std::ops::Deref;
use std::sync::{Arc, OnceLock};

/// A sonar with every kernel's cache. It dereferences to its [`Prepared`] (and on to the
/// [`Sonar`]), so the exact kernels and the lobe query take it as they are.
#[derive(Clone, Debug)]
pub struct FastSonar {
    pub prepared: Prepared,
    /// Fast-path plans by tolerance (built on first use).
    pub plans: PlanCache,
    /// The band's sub-bands for kinked leaves (built on first use; see [`SubBands`]).
    sub_bands: OnceLock<Option<Arc<SubBands>>>,
}

impl FastSonar {
    pub fn new(sonar: Sonar) -> FastSonar {
        FastSonar {
            prepared: Prepared::new(sonar),
            plans: PlanCache::default(),
            sub_bands: OnceLock::new(),
        }
    }

    /// The band's sub-bands for kinked leaves; None where the band is too narrow for them.
    pub fn sub_bands(&self) -> Option<Arc<SubBands>> {
        self.sub_bands
            .get_or_init(|| {
                // (a sub-band of a valid sonar is valid; were one not, the full-band passes
                // stand in)
                SubBands::new(self).ok().flatten().map(Arc::new)
            })
            .clone()
    }
}

impl Deref for FastSonar {
    type Target = Prepared;

    #[inline(always)]
    fn deref(&self) -> &Prepared {
        &self.prepared
    }
}
