//! A sonar prepared for the exact sum: the sonar and the per-bin tables of the spectrum
//! kernel, built once per sonar.

use crate::echo::BandTables;
use crate::sonar::Sonar;
use std::ops::Deref;

/// A sonar with the exact kernel's band tables. It dereferences to its [`Sonar`], so a kernel
/// that needs only the parameters takes `&Sonar` and is handed a `&Prepared` unchanged.
#[derive(Clone, Debug)]
pub struct Prepared {
    pub sonar: Sonar,
    /// Per-bin tables of the spectrum kernel.
    pub tables: BandTables,
}

impl Prepared {
    pub fn new(sonar: Sonar) -> Prepared {
        let atten_at = |x: f64| sonar.atten_at(x);
        let tables = BandTables::new(
            sonar.k0,
            &sonar.wavenumbers,
            &sonar.atten_per_m,
            |x| sonar.wavenumber_at(x),
            if sonar.params.atmosphere.is_some() {
                Some(&atten_at)
            } else {
                None
            },
        );
        Prepared { sonar, tables }
    }
}

impl Deref for Prepared {
    type Target = Sonar;

    #[inline(always)]
    fn deref(&self) -> &Sonar {
        &self.sonar
    }
}
