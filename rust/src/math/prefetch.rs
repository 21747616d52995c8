//! Software prefetch hints for the streams the kernels read in order (scene coordinates, leaf
//! terms): a hint only, it never faults and changes no result.

/// Ask for the cache lines of `v[at..at + N]`, for a stream read in order (nothing where the
/// range leaves `v`: the stream's end is near). One hint per line's worth of bytes from the
/// range's start; a line the range only begins gets the next call's first hint.
#[inline(always)]
pub(crate) fn ahead<T, const N: usize>(v: &[T], at: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        if at.saturating_add(N) > v.len() {
            return;
        }
        let start = v[at..at + N].as_ptr().cast::<i8>();
        for off in (0..N * std::mem::size_of::<T>()).step_by(64) {
            // SAFETY: `start + off` lies inside `v[at..at + N]`; a prefetch only hints.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.add(off)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (v, at);
}
