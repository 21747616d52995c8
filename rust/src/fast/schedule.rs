//! Keeping a pool thread awake across the end of a parallel pass, so that the work after it
//! starts without a futex wake (only the order of events changes, never a result).

/// The tasks of one parallel pass, counted as they start and end, so that a pool thread left
/// without a task before the pass is over stays awake for the work after it
/// ([`TaskCount::run`]).
///
/// Left to itself, a rayon worker idle for some microseconds sleeps; the work after a pass
/// (the transforms beside the leftovers, in parallel) then waits for the futex wake and for
/// the sleeper to start, which matters at 1e5 leaves, where the tasks end tens of
/// microseconds apart. Only the order of events changes, never a result. (The fused pulse
/// does without: its tail is the kinked pass, long beside a wake, and a thread kept awake
/// there only takes a core from it.)
pub(super) struct TaskCount {
    n: usize,
    started: std::sync::atomic::AtomicUsize,
    done: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    /// Set when the pass is over (the count dropped): the waiting thread stops.
    over: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// Whether a thread has been kept awake for this pass (one at most).
    waiter: std::sync::atomic::AtomicBool,
    /// The pool thread running the pass, where it is alone in the pool (none: no thread is
    /// kept awake).
    owner: Option<usize>,
}

/// The longest a thread waits awake for a pass to end.
const AWAKE_WAIT: std::time::Duration = std::time::Duration::from_micros(1000);

impl TaskCount {
    /// `n` tasks, run from the pool thread that drops the count when the pass is over;
    /// `alone`: the pass is the pool's only work. (Where other work may be queued, such as
    /// the other poses of a flight, an idle thread must take that instead of waiting.)
    pub(super) fn new(n: usize, alone: bool) -> TaskCount {
        TaskCount {
            n,
            started: 0.into(),
            done: std::sync::Arc::new(0.into()),
            over: std::sync::Arc::new(false.into()),
            waiter: false.into(),
            owner: rayon::current_thread_index().filter(|_| alone),
        }
    }

    /// Run one task. The first thread other than the pass's own to end a task when every
    /// task has started leaves a job behind that spins until the pass is over (at most
    /// [`AWAKE_WAIT`]; on the pass's own thread, should it take the job, until the tasks
    /// are done), so that it is awake for the work after the pass. The pass's own thread,
    /// ending a task when every task has started, spins until all are done (at most
    /// [`AWAKE_WAIT`]), so that it does not sleep before the pass's end.
    pub(super) fn run<T>(&self, task: impl FnOnce() -> T) -> T {
        use std::sync::atomic::Ordering::{Acquire, Relaxed, Release};
        self.started.fetch_add(1, Relaxed);
        let out = task();
        self.done.fetch_add(1, Release);
        let here = rayon::current_thread_index();
        if self.owner.is_some()
            && here != self.owner
            && self.started.load(Relaxed) == self.n
            && !self.waiter.swap(true, Relaxed)
        {
            let (n, done, over, owner) = (self.n, self.done.clone(), self.over.clone(), self.owner);
            rayon::spawn(move || {
                let own = rayon::current_thread_index() == owner;
                spin_until(|| over.load(Acquire) || (own && done.load(Acquire) >= n));
            });
        } else if self.owner.is_some() && here == self.owner && self.started.load(Relaxed) == self.n
        {
            // The pass's own thread, its last task done while others still run: wait for them
            // awake (a pool thread waiting for a job may sleep and be woken tens of
            // microseconds after the last task ends).
            spin_until(|| self.done.load(Acquire) >= self.n);
        }
        out
    }
}

/// Spin until `ended` holds, at most [`AWAKE_WAIT`].
fn spin_until(ended: impl Fn() -> bool) {
    let t0 = std::time::Instant::now();
    while !ended() && t0.elapsed() < AWAKE_WAIT {
        for _ in 0..32 {
            std::hint::spin_loop();
        }
    }
}

impl Drop for TaskCount {
    fn drop(&mut self) {
        self.over.store(true, std::sync::atomic::Ordering::Release);
    }
}
