//! Term lists kept for reuse between pulses: a pulse heard by receivers gathers each
//! receiver's terms into one list (megabytes at 1e5 leaves), and a fresh list per pulse costs
//! page faults and the kernel's zeroing where a kept one costs nothing.
use crate::echo::term::LeafTerm;
use std::sync::Mutex;

/// Kept lists and their total size in bytes.
static TERM_POOL: Mutex<(Vec<Vec<LeafTerm>>, usize)> = Mutex::new((Vec::new(), 0));
/// The most bytes of lists kept in [`TERM_POOL`].
const TERM_POOL_BYTES: usize = 64 << 20;

/// An empty list with room for `len` terms (a kept one when one is long enough).
pub fn take_terms(len: usize) -> Vec<LeafTerm> {
    let bytes = std::mem::size_of::<LeafTerm>();
    let mut pool = TERM_POOL.lock().unwrap_or_else(|e| e.into_inner());
    match pool.0.iter().rposition(|v| v.capacity() >= len) {
        Some(i) => {
            let v = pool.0.swap_remove(i);
            pool.1 -= v.capacity() * bytes;
            v
        }
        None => {
            drop(pool);
            Vec::with_capacity(len)
        }
    }
}

/// Keep a list for [`take_terms`] (dropped when the pool is full).
pub fn give_terms(mut v: Vec<LeafTerm>) {
    v.clear();
    let bytes = v.capacity() * std::mem::size_of::<LeafTerm>();
    let mut pool = TERM_POOL.lock().unwrap_or_else(|e| e.into_inner());
    if pool.1 + bytes <= TERM_POOL_BYTES {
        pool.1 += bytes;
        pool.0.push(v);
    }
}
