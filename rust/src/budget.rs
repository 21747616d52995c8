//! The memory budget: a process-wide limit on what one call may allocate, the estimates
//! checked against it before anything is allocated, and fallible allocation of vectors whose
//! length comes from the caller. A request beyond the limit, or one the allocator refuses, is
//! an [`Error::TooLarge`] naming the parameter and the size, never an abort.
//!
//! The limit is `DEFAULT_LIMIT_BYTES` until [`set_limit_bytes`] changes it (Python:
//! `batecho.set_memory_limit`).
use crate::error::{Error, Result};
use std::sync::atomic::{AtomicU64, Ordering};

/// The default limit on what one call may allocate: 4 GiB.
pub const DEFAULT_LIMIT_BYTES: u64 = 4 << 30;

static LIMIT: AtomicU64 = AtomicU64::new(DEFAULT_LIMIT_BYTES);

/// The limit in force (bytes).
pub fn limit_bytes() -> u64 {
    LIMIT.load(Ordering::Relaxed)
}

/// Set the limit (bytes, at least 1 MiB); returns the previous one.
pub fn set_limit_bytes(bytes: u64) -> Result<u64> {
    if bytes < 1 << 20 {
        return Err(Error::InvalidInput(format!(
            "the memory limit must be at least 1 MiB (1048576 bytes), got {bytes}"
        )));
    }
    Ok(LIMIT.swap(bytes, Ordering::Relaxed))
}

/// A size in bytes for people, in binary units as the limit is set: "4.0 GiB", "512.0 MiB".
pub fn human(bytes: f64) -> String {
    let units = [
        ("TiB", 1024f64.powi(4)),
        ("GiB", 1024f64.powi(3)),
        ("MiB", 1024f64.powi(2)),
        ("KiB", 1024.0),
    ];
    for (name, scale) in units {
        if bytes >= scale {
            return format!("{:.1} {name}", bytes / scale);
        }
    }
    format!("{bytes:.0} bytes")
}

/// `Ok` when `bytes` (an estimate, f64 so that it cannot overflow) is within the limit;
/// otherwise `TooLarge` with `what` (the request, naming its parameters) and `pieces` (how to
/// get the work done in pieces).
pub fn check(bytes: f64, what: impl FnOnce() -> String, pieces: &str) -> Result<()> {
    let limit = limit_bytes();
    if bytes.is_finite() && bytes <= limit as f64 {
        return Ok(());
    }
    Err(Error::TooLarge(format!(
        "{} needs about {}, over batecho's memory limit of {}; {pieces} (or raise the limit \
         with batecho.set_memory_limit)",
        what(),
        human(bytes),
        human(limit as f64)
    )))
}

/// Bytes per band bin a sonar keeps once (its own tables, the exact kernel's, a fast plan of
/// at most 16 nodes with its Lagrange rows and FFT, the sub-bands' copies of the same).
const SONAR_BYTES_PER_BIN: f64 = 800.0;
/// Bytes per band bin each worker thread holds while summing (spreading grids of up to 16
/// channels on a grid of about twice the bins, the spectrum).
const THREAD_BYTES_PER_BIN: f64 = 600.0;
/// Bytes per record sample each worker thread holds (the impulse, the inverse FFT's buffers).
const THREAD_BYTES_PER_SAMPLE: f64 = 24.0;

/// What a sonar of `m` band bins and records of `n` samples needs (bytes), with `threads`
/// worker threads: its tables and plans once, and each thread's working arrays.
pub fn sonar_bytes(m: usize, n: usize, threads: usize) -> f64 {
    m as f64 * SONAR_BYTES_PER_BIN
        + threads as f64 * (m as f64 * THREAD_BYTES_PER_BIN + n as f64 * THREAD_BYTES_PER_SAMPLE)
}

/// Memory per counting branch piece of a pose (bytes): its member, its term, its shading
/// target and factor.
pub const BYTES_PER_PIECE: f64 = 320.0;

/// Memory per leaf of a scene (bytes): the arrays, their copies in BVH order, the BVH.
pub const BYTES_PER_LEAF: f64 = 400.0;

/// Memory per branch segment of a scene (bytes): the arrays, the boxes, the BVH, the map of
/// end points.
pub const BYTES_PER_SEGMENT: f64 = 400.0;

/// Memory per joint of two branch segments at a shared end point (bytes): each segment's
/// entry of the other.
pub const BYTES_PER_JOINT: f64 = 8.0;

/// What `simulate` returns for `p` poses (bytes): each pose's spectrum (`m` complex bins) and
/// impulse (`n` samples, when asked for), held per pose, gathered, and handed to the caller.
pub fn echoes_bytes(p: usize, m: usize, n: usize, impulse: bool) -> f64 {
    let per_pose = 48.0 * m as f64 + if impulse { 16.0 * n as f64 } else { 0.0 };
    p as f64 * per_pose
}

/// An empty vector with room for `n` values, or `TooLarge` naming `what`.
pub fn with_capacity<T>(n: usize, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|_| refused(n, std::mem::size_of::<T>(), what))?;
    Ok(v)
}

/// `n` copies of `value`, or `TooLarge` naming `what`.
pub fn filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// Room for `more` values in `v`, or `TooLarge` naming `what`.
pub fn reserve<T>(v: &mut Vec<T>, more: usize, what: &str) -> Result<()> {
    v.try_reserve_exact(more)
        .map_err(|_| refused(v.len().saturating_add(more), std::mem::size_of::<T>(), what))
}

fn refused(n: usize, size: usize, what: &str) -> Error {
    Error::TooLarge(format!(
        "{what}: the allocation of {n} values ({}) was refused by the system; work in \
         smaller pieces",
        human(n as f64 * size as f64)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estimate_over_the_limit_names_the_request_and_the_sizes() {
        let e = check(1e13, || "simulate with 9 poses".into(), "split the poses").unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, Error::TooLarge(_)));
        assert!(
            msg.contains("simulate with 9 poses") && msg.contains("9.1 TiB"),
            "{msg}"
        );
        assert!(
            msg.contains("split the poses") && msg.contains("set_memory_limit"),
            "{msg}"
        );
    }

    #[test]
    fn a_non_finite_estimate_is_refused() {
        assert!(check(f64::INFINITY, || "x".into(), "").is_err());
        assert!(check(f64::NAN, || "x".into(), "").is_err());
        assert!(check(1e3, || "x".into(), "").is_ok());
    }

    #[test]
    fn an_impossible_allocation_is_an_error_not_an_abort() {
        let e = with_capacity::<f64>(usize::MAX / 4, "the test's vector").unwrap_err();
        assert!(e.to_string().contains("the test's vector"), "{e}");
        assert!(filled(usize::MAX / 16, 0.0f64, "v").is_err());
    }

    #[test]
    fn the_limit_below_one_mebibyte_is_refused() {
        assert!(set_limit_bytes(1000).is_err());
        assert_eq!(limit_bytes(), DEFAULT_LIMIT_BYTES);
    }
}
