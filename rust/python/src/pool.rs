//! The worker threads of this process: every call into the core runs on them, with the GIL
//! released ([`released`]); the long ones ([`interruptible`]) while the calling thread keeps
//! answering Ctrl-C.
//!
//! Rayon's global pool does not survive `fork()`: a child inherits a pool whose threads were
//! never copied, and its first parallel call waits for them forever (Gymnasium's async vector
//! environments and `multiprocessing` fork by default on Linux). So the pool is this process's
//! own, made on first use and made again in a child whose process id differs. Its size is
//! rayon's default (`RAYON_NUM_THREADS`, else one thread per core).

use batecho::interrupt::Interrupt;
use pyo3::exceptions::PyRuntimeError;
use pyo3::{PyResult, Python};
use rayon::{ThreadPool, ThreadPoolBuilder};
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::mpsc::{sync_channel, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How often a thread waiting on [`interruptible`] work looks for Python's signals.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

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

/// `f` with the GIL released, on this process's pool, given an interrupt that it looks at
/// between poses. Meanwhile the calling thread looks for Python's signals every
/// [`SIGNAL_POLL`] (Python runs their handlers on the main thread only): when a handler
/// raises (Ctrl-C's `KeyboardInterrupt`), the interrupt is raised, `f` is waited for (it then
/// stops within about one pose's time) and the handler's exception is returned, whatever `f`
/// returned. A panic in `f` reaches the caller as it would from [`released`]. Without a pool,
/// `f` runs on the calling thread, to its end.
pub(crate) fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    f: impl FnOnce(&Interrupt) -> T + Send + 'static,
) -> PyResult<T> {
    let Some(p) = pool() else {
        return Ok(py.detach(|| f(&Interrupt::new())));
    };
    let stop = Arc::new(Interrupt::new());
    let (tx, rx) = sync_channel(1);
    let theirs = stop.clone();
    p.spawn(move || {
        // (a panic must not unwind out of a spawned job: rayon would abort the process)
        let out = catch_unwind(AssertUnwindSafe(|| f(&theirs)));
        let _ = tx.send(out);
    });
    let (mut signal, mut rx) = (None, rx);
    loop {
        // (the receiver goes with the wait and comes back: it is not shared between threads)
        let got;
        (got, rx) = py.detach(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        match got {
            Ok(Ok(out)) => return signal.map_or(Ok(out), Err),
            Ok(Err(panic)) => resume_unwind(panic),
            Err(RecvTimeoutError::Timeout) => {
                if signal.is_none() {
                    if let Err(e) = py.check_signals() {
                        stop.raise();
                        signal = Some(e);
                    }
                }
            }
            // (the job sends before it drops the sender; were it dropped unrun, say so)
            Err(RecvTimeoutError::Disconnected) => {
                return Err(PyRuntimeError::new_err(
                    "the worker thread ended without a result",
                ))
            }
        }
    }
}
