//! Errors of the pure-Rust core. Every failure is a value, never a panic; the bindings turn
//! these into Python `ValueError`s (`MemoryError` for [`Error::TooLarge`]) with the same
//! message.

use std::fmt;

/// An input or model error, with a message that names the offending input.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// The caller gave a value outside its domain (NaN, negative radius, band above Nyquist...).
    InvalidInput(String),
    /// A leaf is closer to a pulse position than the sonar's `min_range`.
    TooClose {
        pose: usize,
        leaf: usize,
        range: f64,
        min_range: f64,
    },
    /// A leaf is closer to a receiver of its own (docs/model.md §5a) than `min_range`.
    TooCloseToReceiver {
        pose: usize,
        receiver: usize,
        leaf: usize,
        range: f64,
        min_range: f64,
    },
    /// A branch's surface is closer to a receiver of its own than `min_range` (or the
    /// receiver lies inside it: `range <= 0`).
    BranchTooCloseToReceiver {
        pose: usize,
        receiver: usize,
        branch: usize,
        range: f64,
        min_range: f64,
    },
    /// A branch's surface is closer to a pulse position than `min_range` (or the pulse lies
    /// inside it: `range <= 0`).
    BranchTooClose {
        pose: usize,
        branch: usize,
        range: f64,
        min_range: f64,
    },
    /// An OBJ/MTL file could not be read or understood.
    Obj(String),
    /// A request larger than the memory limit (`budget`), or one the allocator refused; the
    /// bindings raise `MemoryError`.
    TooLarge(String),
    /// The caller raised the call's [`crate::interrupt::Interrupt`] before it ended.
    Interrupted,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidInput(msg) | Error::Obj(msg) | Error::TooLarge(msg) => f.write_str(msg),
            Error::Interrupted => f.write_str("interrupted before the call ended"),
            Error::TooClose { pose, leaf, range, min_range } => write!(
                f,
                "leaf {leaf} is {range:.3e} m from pose {pose}, closer than min_range_m = {min_range} m; \
                 the far-field echo model does not hold there (move the pose, lower min_range_m, \
                 or pass too_close=\"skip\" to leave such leaves out)",
                min_range = short(*min_range)
            ),
            Error::TooCloseToReceiver { pose, receiver, leaf, range, min_range } => write!(
                f,
                "leaf {leaf} is {range:.3e} m from receiver {receiver} of pose {pose}, closer than \
                 min_range_m = {min_range} m; the far-field echo model does not hold there (move \
                 the receiver or the pose, lower min_range_m, or pass too_close=\"skip\")",
                min_range = short(*min_range)
            ),
            Error::BranchTooCloseToReceiver { pose, receiver, branch, range, min_range } => write!(
                f,
                "branch {branch} is {range:.3e} m from receiver {receiver} of pose {pose} (inside \
                 it where negative or zero), closer than min_range_m = {min_range} m; the \
                 far-field echo model does not hold there (move the receiver or the pose, lower \
                 min_range_m, or pass too_close=\"skip\" to leave such pieces out)",
                min_range = short(*min_range)
            ),
            Error::BranchTooClose { pose, branch, range, min_range } if *range <= 0.0 => write!(
                f,
                "pose {pose} lies inside branch {branch} or on its surface (its side is {:.3e} m away, min_range_m = {min_range} m); \
                 move the pose, or pass too_close=\"skip\" to leave such pieces out",
                // (`abs`, so that a pose on the surface reads 0, not -0)
                range.abs(),
                min_range = short(*min_range)
            ),
            Error::BranchTooClose { pose, branch, range, min_range } => write!(
                f,
                "branch {branch} is {range:.3e} m from pose {pose}, closer than min_range_m = {min_range} m; \
                 the far-field echo model does not hold there (move the pose, lower min_range_m, \
                 or pass too_close=\"skip\" to leave such pieces out)",
                min_range = short(*min_range)
            ),
        }
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;

/// A number for a message: as given where it is near 1 (`1e-4 <= |x| < 1e12`, or 0), else in
/// a few digits (an absurd value would print hundreds).
pub(crate) fn short(x: f64) -> String {
    if x == 0.0 || (1e-4..1e12).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:.3e}")
    }
}

/// A computed number for a message, in four digits: fixed where it is near 1
/// (`1e-3 <= |x| < 1e6`, or 0), else in exponent form (a tiny `k a` would read 0.0000).
pub(crate) fn four_digits(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

/// Shorthand for an `InvalidInput` error.
pub(crate) fn invalid<T>(msg: impl Into<String>) -> Result<T> {
    Err(Error::InvalidInput(msg.into()))
}
