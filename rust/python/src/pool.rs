//! The worker threads of this process: every call into the core runs on them, with the GIL
//! released ([`released`]).
//!
//! Rayon's global pool does not survive `fork()`: a child inherits a pool whose threads were
//! never copied, and its first parallel call waits for them forever (Gymnasium's async vector
//! environments and `multiprocessing` fork by default on Linux). So the pool is this process's
//! own, made on first use and made again in a child whose process id differs. Its size is
//! rayon's default (`RAYON_NUM_THREADS`, else one thread per core).

use pyo3::Python;
use rayon::{ThreadPool, ThreadPoolBuilder};
use std::sync::{Arc, Mutex};

/// The pool and the process that made it.
static POOL: Mutex<Option<(u32, Arc<ThreadPool>)>> = Mutex::new(None);

/// This process's pool (None if no thread could be started).
fn pool() -> Option<Arc<ThreadPool>> {
    let pid = std::process::id();
    let mut slot = POOL.lock().unwrap_or_else(|e| e.into_inner());
    match slot.as_ref() {
        Some((owner, p)) if *owner == pid => return Some(p.clone()),
        // (a parent's pool: its threads are not here, so it is left alone, never joined)
        Some(_) => std::mem::forget(slot.take()),
        None => {}
    }
    let p = Arc::new(ThreadPoolBuilder::new().build().ok()?);
    *slot = Some((pid, p.clone()));
    Some(p)
}

/// `f` with the GIL released, on this process's pool (on the calling thread, one thread
/// alone, if the pool cannot be made).
pub(crate) fn released<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> T {
    py.detach(|| match pool() {
        Some(p) => p.install(f),
        None => f(),
    })
}
