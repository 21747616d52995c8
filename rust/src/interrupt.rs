//! A caller's request that a long call stop early. Another thread raises it (the Python
//! binding does on Ctrl-C); a call looks at it between poses, so it stops within about one
//! pose's time with [`Error::Interrupted`] and its partial results are dropped. Looking costs
//! one relaxed load, and a call never interrupted gives the same bits as before.
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, Ordering};

/// A request to stop, not raised until [`Interrupt::raise`].
#[derive(Debug, Default)]
pub struct Interrupt(AtomicBool);

/// An interrupt that nothing raises: for calls that run to their end.
pub static NEVER: Interrupt = Interrupt::new();

impl Interrupt {
    pub const fn new() -> Interrupt {
        Interrupt(AtomicBool::new(false))
    }

    /// Ask the calls that look at this interrupt to stop.
    pub fn raise(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// `Err(Error::Interrupted)` once raised.
    #[inline]
    pub fn check(&self) -> Result<()> {
        if self.0.load(Ordering::Relaxed) {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interrupt_passes_until_raised_and_then_says_interrupted() {
        let stop = Interrupt::new();
        assert_eq!(stop.check(), Ok(()));
        stop.raise();
        assert_eq!(stop.check(), Err(Error::Interrupted));
        assert_eq!(NEVER.check(), Ok(()));
    }
}
